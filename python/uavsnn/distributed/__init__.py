"""Work spread over a Ray cluster: a laptop's local one (``ray.init()``) or an existing cluster.

Three jobs outgrow one machine, and each runs here on Ray's tasks and actors
(``docs/distributed.md``):

- **dataset builds**: every recording (rendered or real) is simulated and cut into windows by a
  task; the build's splits, seeds and window draws are made in the driver exactly as on one
  machine, so the dataset is the serial one, array for array (:class:`Runner`);
- **experiments**: ``uavsnn reproduce`` and the sweep script run trainings and evaluations as
  tasks (:func:`train_task`, :func:`evaluate_task`, :func:`noise_task`);
- **many streams**: one :class:`~uavsnn.Detector` per stream, each in a Ray actor that opens
  its own source (file or UDP port), so events never pass through the driver
  (:func:`detect_streams`).

Ray is optional (``pip install 'uavsnn[ray]'``): this package imports it only when asked to
connect, and ``import uavsnn`` never does. Without Ray every job runs serially through
:data:`SERIAL`, the same code path with the same results.

Networks are sent between processes as their config, weights and identification (what a model
file holds), as a network pickles itself (``Network.__reduce__``).

The package's modules: :mod:`~uavsnn.distributed.cluster` (the runners and joining a cluster),
:mod:`~uavsnn.distributed.tasks` (the experiments' units of work) and
:mod:`~uavsnn.distributed.streams` (many streams); every public name is importable from here.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from uavsnn.distributed.cluster import (
    CONNECT_TIMEOUT_S,
    MAX_CPUS,
    RAY_HINT,
    SERIAL,
    RayRunner,
    Runner,
    SerialRunner,
    add_ray_option,
    connect,
    ray_available,
    runner_for,
)
from uavsnn.distributed.streams import MAX_STREAMS, STOP_WAIT_S, StreamResult, detect_streams
from uavsnn.distributed.tasks import evaluate_task, noise_task, train_task
from uavsnn.network import Network

__all__ = [
    "CONNECT_TIMEOUT_S",
    "MAX_CPUS",
    "MAX_STREAMS",
    "RAY_HINT",
    "SERIAL",
    "STOP_WAIT_S",
    "RayRunner",
    "Runner",
    "SerialRunner",
    "StreamResult",
    "add_ray_option",
    "connect",
    "detect_streams",
    "evaluate_task",
    "noise_task",
    "ray_available",
    "runner_for",
    "train_task",
]


def _network_from_state(
    config: dict[str, Any], weights: dict[str, np.ndarray], identification: Any = None
) -> Network:
    """A network pickled by an older uavsnn, which registered its pickling here (a network
    pickles itself now: ``Network.__reduce__``)."""
    return Network._restore(config, weights, identification, None)
