"""Fitting models to measured loops: the inverse of ``sim`` (identification and diagnose).

numpy/scipy only; it calls ``sim`` to simulate and is called by ``agent`` and the command.
"""
