"""A trainer that knows nothing about the model: minibatch Adam with early stopping on a validation set."""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass

import torch
from torch import nn


@dataclass(frozen=True)
class FitSettings:
    epochs: int = 2000
    patience: int = 100
    batch_size: int = 0
    """0: full batch."""
    learning_rate: float = 1e-2
    weight_decay: float = 0.0
    seed: int = 0
    optimiser: str = "adam"
    """``adam`` (minibatch) or ``lbfgs`` (full batch, a second-order method like MATLAB's default trainer)."""


@dataclass(frozen=True)
class FitResult:
    best_epoch: int
    train_loss: float
    val_loss: float
    epochs_run: int


def fit(
    model: nn.Module,
    x_train,
    y_train,
    x_val,
    y_val,
    loss_fn: Callable,
    settings: FitSettings,
    on_epoch: Callable[[int, float, float], None] | None = None,
) -> FitResult:
    """Train in place; on return the model holds the weights of its best validation epoch."""
    torch.manual_seed(settings.seed)
    if settings.optimiser == "lbfgs":
        opt = torch.optim.LBFGS(
            model.parameters(), lr=settings.learning_rate, max_iter=20, line_search_fn="strong_wolfe"
        )
    else:
        opt = torch.optim.Adam(model.parameters(), lr=settings.learning_rate, weight_decay=settings.weight_decay)
    n = x_train.shape[0]
    batch = n if settings.optimiser == "lbfgs" else (settings.batch_size or n)
    best, best_state, best_epoch, train_loss = float("inf"), None, -1, float("nan")
    epoch = 0
    for epoch in range(settings.epochs):
        model.train()
        order = torch.randperm(n)
        for i in range(0, n, batch):
            idx = order[i : i + batch]

            def closure(idx=idx):
                opt.zero_grad()
                loss = loss_fn(model(x_train[idx]), y_train[idx])
                loss.backward()
                return loss

            opt.step(closure)
        model.eval()
        with torch.no_grad():
            train_loss = float(loss_fn(model(x_train), y_train))
            val = float(loss_fn(model(x_val), y_val))
        if on_epoch:
            on_epoch(epoch, train_loss, val)
        if val < best:
            best, best_state, best_epoch = val, copy.deepcopy(model.state_dict()), epoch
        elif epoch - best_epoch > settings.patience:
            break
    model.load_state_dict(best_state)
    return FitResult(best_epoch, train_loss, best, epoch + 1)
