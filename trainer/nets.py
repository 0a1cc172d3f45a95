"""The networks, with normalisation inside so that the ONNX graph takes raw features.

``ThesisMLP``: thesis 4.6, 100 OP samples -> 25 sigmoid units -> (fs_pct, fd_pct).
``CycleEnsemble``: K small MLPs on the cycle features; outputs their mean, their
spread (the uncertainty) and an out-of-distribution score of the input.
``WindowEnsemble``: K small dilated convolutional networks on a window's OP and PV (``detect.sequence``);
outputs their mean log-odds that the window shows a valve fault.
"""

from __future__ import annotations

import torch
from torch import nn


class Standardise(nn.Module):
    def __init__(self, mean: torch.Tensor, std: torch.Tensor):
        super().__init__()
        self.register_buffer("mean", mean.float())
        self.register_buffer("std", std.float().clamp_min(1e-6))

    def forward(self, x):
        return (x - self.mean) / self.std


class Unstandardise(Standardise):
    def forward(self, x):
        return x * self.std + self.mean


class ThesisMLP(nn.Module):
    def __init__(self, x_mean, x_std, y_mean, y_std, hidden: int = 25):
        super().__init__()
        self.inp = Standardise(x_mean, x_std)
        self.net = nn.Sequential(nn.Linear(x_mean.numel(), hidden), nn.Sigmoid(), nn.Linear(hidden, 2))
        self.out = Unstandardise(y_mean, y_std)

    def forward(self, op_window):  # [B, 100] -> [B, 2]
        return self.out(self.net(self.inp(op_window)))


class CycleMLP(nn.Module):
    def __init__(self, x_mean, x_std, y_mean, y_std, hidden: int = 64):
        super().__init__()
        self.inp = Standardise(x_mean, x_std)
        n_in = x_mean.numel()
        self.net = nn.Sequential(
            nn.Linear(n_in, hidden), nn.Tanh(), nn.Linear(hidden, hidden), nn.Tanh(), nn.Linear(hidden, 2)
        )
        self.out = Unstandardise(y_mean, y_std)

    def forward(self, features):  # [B, F] -> [B, 2]
        return self.out(self.net(self.inp(features)))


class OodScore(nn.Module):
    """Mahalanobis distance in the training set's leading principal components plus the residual off them,

    scaled so that 1.0 is the 99th percentile over the training windows.
    """

    def __init__(self, x_mean, x_std, components, sv, resid_scale, q99):
        super().__init__()
        self.inp = Standardise(x_mean, x_std)
        self.register_buffer("components", components.float())  # [F, k]
        self.register_buffer("sv", sv.float())  # [k]
        self.register_buffer("resid_scale", resid_scale.float().reshape(()))
        self.register_buffer("q99", q99.float().reshape(()))

    def raw(self, features):
        z = self.inp(features)  # [B, F]
        proj = z @ self.components  # [B, k]
        resid = z - proj @ self.components.T  # [B, F]
        d2 = ((proj / self.sv) ** 2).mean(dim=1) + (resid**2).sum(dim=1) / self.resid_scale
        return torch.sqrt(d2)  # [B]

    def forward(self, features):
        return self.raw(features) / self.q99


class CycleEnsemble(nn.Module):
    def __init__(self, members: list[CycleMLP], ood: OodScore):
        super().__init__()
        self.members = nn.ModuleList(members)
        self.ood = ood

    def forward(self, features):  # [B, F] -> [B, 2], [B, 2], [B]
        preds = torch.stack([m(features) for m in self.members], dim=0)  # [K, B, 2]
        return preds.mean(dim=0), preds.std(dim=0), self.ood(features)


def fit_ood(x: torch.Tensor, k: int = 12) -> OodScore:
    mean, std = x.mean(dim=0), x.std(dim=0)
    z = (x - mean) / std.clamp_min(1e-6)
    _, s, vh = torch.linalg.svd(z, full_matrices=False)
    components = vh[:k].T
    sv = s[:k] / (z.shape[0] - 1) ** 0.5
    resid = z - (z @ components) @ components.T
    resid_scale = (resid**2).sum(dim=1).mean().clamp_min(1e-6)
    ood = OodScore(mean, std, components, sv, resid_scale, torch.tensor(1.0))
    with torch.no_grad():
        ood.q99 = torch.quantile(ood.raw(x), 0.99)
    return ood


class WindowNet(nn.Module):
    """Dilated 1-D convolutions over a window's channels (``detect.sequence.CHANNELS``), then the mean and the
    maximum over time of the last layer's units, then one log-odds.  Two layers at the full rate (a slip's edge
    is a sample or two), the rest at half the rate with dilations 2, 4 and 8: the receptive field is about 120
    samples, a stuck stretch and its slip.  Any length: the pooling is over time."""

    def __init__(self, channels: int = 5, hidden: int = 16, kernel: int = 7):
        super().__init__()
        pad = kernel // 2
        self.full_rate = nn.Sequential(
            nn.Conv1d(channels, hidden, kernel, padding=pad), nn.GELU(),
            nn.Conv1d(hidden, hidden, kernel, padding=2 * pad, dilation=2), nn.GELU(),
        )  # fmt: skip
        self.half_rate = nn.Sequential(
            *[m for d in (2, 4, 8) for m in (nn.Conv1d(hidden, hidden, kernel, padding=pad * d, dilation=d), nn.GELU())]
        )
        self.out = nn.Linear(2 * hidden, 1)

    def forward(self, x):  # [B, C, N] -> [B]
        z = self.half_rate(nn.functional.avg_pool1d(self.full_rate(x), 2))  # [B, H, N / 2]
        return self.out(torch.cat([z.mean(dim=-1), z.amax(dim=-1)], dim=1)).squeeze(1)


class WindowEnsemble(nn.Module):
    def __init__(self, members: list[WindowNet]):
        super().__init__()
        self.members = nn.ModuleList(members)

    def forward(self, x):  # [B, C, N] -> [B] mean log-odds
        return torch.stack([m(x) for m in self.members], dim=0).mean(dim=0)


def _as_conv2d(conv: nn.Conv1d) -> nn.Conv2d:
    """``conv`` as a 2-D convolution of height one, the same weights."""
    out = nn.Conv2d(
        conv.in_channels, conv.out_channels, (1, conv.kernel_size[0]),
        padding=(0, conv.padding[0]), dilation=(1, conv.dilation[0]),
    )  # fmt: skip
    out.weight.data = conv.weight.data[:, :, None, :].clone()
    out.bias.data = conv.bias.data.clone()
    return out


def _height_one(layers: nn.Sequential) -> nn.Sequential:
    """``layers`` with each 1-D convolution made 2-D (``_as_conv2d``), the rest as they are: the same indices, so
    the same parameter names (``trainer.window_net.read_onnx`` reads them back by name)."""
    return nn.Sequential(*[_as_conv2d(m) if isinstance(m, nn.Conv1d) else m for m in layers])


class _WindowNet2d(nn.Module):
    """A ``WindowNet`` computed on [B, C, 1, N]: its convolutions, pooling and GELUs, height one."""

    def __init__(self, net: WindowNet):
        super().__init__()
        self.full_rate, self.half_rate = _height_one(net.full_rate), _height_one(net.half_rate)
        self.out = net.out

    def forward(self, x):  # [B, C, 1, N] -> [B]
        z = self.half_rate(nn.functional.avg_pool2d(self.full_rate(x), (1, 2)))[:, :, 0, :]  # [B, H, N / 2]
        return self.out(torch.cat([z.mean(dim=-1), z.amax(dim=-1)], dim=1)).squeeze(1)


class WindowEnsemble2d(nn.Module):
    """The same function as a ``WindowEnsemble``, for export: the input [B, C, N] as an image of height one, so that
    every convolution is 2-D.  onnxruntime runs 2-D convolutions in its blocked layout (NCHWc) and 1-D ones as
    plain im2col products: 0.24 against 0.39 ms a chunk of 600 samples here (docs/scaling.md), logits within 2e-6."""

    def __init__(self, ensemble: WindowEnsemble):
        super().__init__()
        self.members = nn.ModuleList([_WindowNet2d(m) for m in ensemble.members])

    def forward(self, x):  # [B, C, N] -> [B] mean log-odds
        x = x.unsqueeze(2)
        return torch.stack([m(x) for m in self.members], dim=0).mean(dim=0)
