"""The experiments' units of work, run as Ray tasks by ``uavsnn reproduce`` and the sweep
script (or serially, through :data:`uavsnn.distributed.SERIAL`)."""

from __future__ import annotations

from typing import Any

from uavsnn.network import Network


def train_task(
    config: dict[str, Any], seed: int, windows: Any, train_kwargs: dict[str, Any]
) -> Any:
    """Train a new ``Network(config, seed=seed)`` on ``windows``; returns the
    :class:`~uavsnn.training.TrainingResult` (its network trained)."""
    from uavsnn.training import train

    return train(Network(config, seed=seed), windows, **train_kwargs)


def evaluate_task(network: Network, data: Any, kwargs: dict[str, Any]) -> Any:
    """:func:`uavsnn.evaluation.evaluate` of ``network`` on ``data``."""
    from uavsnn.evaluation import evaluate

    return evaluate(network, data, **kwargs)


def noise_task(networks: dict[str, Network], data: Any, fraction: float, seed: int) -> Any:
    """One noise level of :func:`uavsnn.experiments.noise_sweep` (its points)."""
    from uavsnn.experiments import noise_level

    return noise_level(networks, data, fraction, seed=seed)
