"""The spiking network of ``docs/model.md``, dense and frame by frame, in plain NumPy.

This is the independent reference the event-driven engine is tested against. It is written to be
read beside ``docs/model.md`` — each function names the section it implements — and makes no
attempt at speed.

Times. Inside this module a layer's spikes are a *time map*: a ``float32`` array of shape
``(channels, rows, cols)`` holding ``t - t0`` in microseconds where a neuron fired and ``+inf``
where it did not (§1's time-embedded frame, one per channel). ``float32`` holds every integer
microsecond exactly below 2**24 µs (16.7 s), which :func:`time_embedded_frame` checks. Spike
arrays handed back carry absolute times, ``t0 + (t - t0)``.

Potentials. A conv neuron's potential ``V(τ)`` at each time ``τ`` is the sum of the weights of
its inputs of time ``<= τ``: the neuron's inputs are sorted by time and summed cumulatively, and
``V >= θ`` is tested only at the end of each run of equal times, so every spike at ``τ`` counts
before any crossing at ``τ`` is decided (§3, "Spikes at the same time"). Potentials are float64
sums of the float32 weights, exact whatever the order (§3, "Arithmetic of V"); every decision
(crossing, lateral inhibition, winner order) uses them, and a reported potential ``v`` is rounded
to float32.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

__all__ = [
    "CONV_LAYERS",
    "DETECTION_DTYPE",
    "LAYERS",
    "SPIKE_DTYPE",
    "convergence",
    "gabor_kernels",
    "learning_rates",
    "pent_thresholds",
    "receptive_field",
    "run_window",
    "stdp_step",
    "time_embedded_frame",
]

LAYERS = ("conv1", "pool1", "conv2", "pool2", "conv3")
CONV_LAYERS = ("conv1", "conv2", "conv3")

SPIKE_DTYPE = np.dtype([("t", "<u8"), ("map", "<u2"), ("row", "<u2"), ("col", "<u2"), ("v", "<f4")])
# A conv3 spike as a detection (§5), in continuous sensor coordinates where pixel (x, y) covers
# [x, x + 1) × [y, y + 1): the centre (x, y) of its receptive field and the half-open box
# [x0, x1) × [y0, y1) of the input spikes that caused it (§5, ``_causes``).
DETECTION_DTYPE = np.dtype(
    [
        ("t", "<u8"),
        ("map", "<u2"),
        ("row", "<u2"),
        ("col", "<u2"),
        ("x", "<f4"),
        ("y", "<f4"),
        ("x0", "<u2"),
        ("y0", "<u2"),
        ("x1", "<u2"),
        ("y1", "<u2"),
    ]
)

_NEVER = np.float32(np.inf)
_MAX_EXACT_US = 2**24  # float32 holds every integer below this exactly


# ------------------------------------------------------------------------------------------------
# §1 Input


def time_embedded_frame(
    t: np.ndarray, x: np.ndarray, y: np.ndarray, t0: int, width: int, height: int
) -> np.ndarray:
    """§1: the window's input as a ``(1, height, width)`` float32 time map.

    Each pixel holds ``t - t0`` of its first spike in the given order, ``+inf`` if it has none.
    """
    t = np.asarray(t, dtype=np.uint64)
    x = np.asarray(x, dtype=np.int64)
    y = np.asarray(y, dtype=np.int64)
    if not (len(t) == len(x) == len(y)):
        raise ValueError(f"t, x, y differ in length: {len(t)}, {len(x)}, {len(y)}")
    if len(t) and (np.any(np.diff(t.astype(np.int64)) < 0)):
        raise ValueError("input spikes are not sorted by t")
    frame = np.full((1, height, width), _NEVER, dtype=np.float32)
    for ti, xi, yi in zip(t.tolist(), x.tolist(), y.tolist(), strict=True):
        if not (0 <= xi < width and 0 <= yi < height):
            raise ValueError(f"spike at ({xi}, {yi}) is outside the {width}x{height} sensor")
        if ti < t0 or ti - t0 >= _MAX_EXACT_US:
            raise ValueError(f"spike time {ti} is not in [t0, t0 + 2**24) for t0={t0}")
        if frame[0, yi, xi] == _NEVER:  # a pixel fires once: its first spike
            frame[0, yi, xi] = np.float32(ti - t0)
    return frame


# ------------------------------------------------------------------------------------------------
# §2 Geometry


def _padding_lo(padding: str, k: int) -> int:
    """Padding before position 0 of a conv layer: ``(k - 1) // 2`` for same, 0 for valid."""
    return (k - 1) // 2 if padding == "same" else 0


def _conv_out_size(padding: str, size: int, k: int) -> int:
    if padding == "same":
        return size
    out = size - k + 1
    if out < 1:
        raise ValueError(f"valid conv with kernel {k} does not fit an input of size {size}")
    return out


def _pool_out_size(padding: str, size: int, k: int, s: int) -> int:
    if padding == "same":
        return math.ceil(size / s)
    if size < k:
        raise ValueError(f"valid pool with kernel {k} does not fit an input of size {size}")
    return (size - k) // s + 1


def _layer_kind(layer: str) -> str:
    return "conv" if layer.startswith("conv") else "pool"


# ------------------------------------------------------------------------------------------------
# §3 Conv layers: cumulative potentials per distinct input time, first crossing, latching


def _conv_crossings(
    in_times: np.ndarray, weights: np.ndarray, thresholds: np.ndarray, padding: str
) -> tuple[np.ndarray, np.ndarray]:
    """Every neuron's first crossing time and its potential then, without any inhibition.

    ``in_times`` is the input time map ``(C, H, W)``; ``weights`` ``(M, C, k, k)`` float32;
    ``thresholds`` ``(M,)`` float32. Returns ``(cross_t, cross_v)``, each ``(M, Ho, Wo)``:
    ``cross_t`` (float32) is ``+inf`` for neurons that never cross; ``cross_v`` is the float64
    potential at the crossing.

    Each neuron's inputs are taken in time order and their weights summed cumulatively; the
    neuron crosses at the first input time ``t`` whose cumulative sum, taken over *every* input
    of time ``<= t`` (the end of a run of equal times), reaches its threshold.
    """
    maps, channels, k, _ = weights.shape
    _, height, width = in_times.shape
    p_lo = _padding_lo(padding, k)
    out_h = _conv_out_size(padding, height, k)
    out_w = _conv_out_size(padding, width, k)

    # Explicit padding: padded positions hold +inf, so they never spike.
    pad_h = (p_lo, out_h + k - 1 - height - p_lo)
    pad_w = (p_lo, out_w + k - 1 - width - p_lo)
    padded = np.pad(in_times, ((0, 0), pad_h, pad_w), constant_values=np.inf)

    # Cross-correlation: neuron (oy, ox) reads padded input (c, oy + dy, ox + dx) through
    # synapse (c, dy, dx). ``reads[s, oy, ox]`` is the input time behind synapse s, with the
    # synapses in the order of ``weights[m].ravel()``.
    reads = sliding_window_view(padded, (k, k), axis=(1, 2))  # (C, Ho, Wo, k, k)
    reads = reads.transpose(0, 3, 4, 1, 2).reshape(channels * k * k, out_h, out_w)
    order = np.argsort(reads, axis=0, kind="stable")  # each neuron's synapses by input time
    times = np.take_along_axis(reads, order, axis=0)
    # V(t) counts every input of time <= t, so a crossing is decided only at the last input of
    # a run of equal times (§3, "Spikes at the same time"), and never at a silent input.
    decides = np.isfinite(times)
    decides[:-1] &= times[:-1] != times[1:]

    cross_t = np.full((maps, out_h, out_w), _NEVER, dtype=np.float32)
    cross_v = np.zeros((maps, out_h, out_w), dtype=np.float64)
    for m in range(maps):
        # §3: float64 sums of the float32 weights (exact in any order), against float64(θ).
        w = weights[m].astype(np.float32).astype(np.float64).ravel()
        potential = np.cumsum(w[order], axis=0)
        theta = np.float64(np.float32(thresholds[m]))
        crossed = decides & (potential >= theta)
        fires = crossed.any(axis=0)
        first = np.argmax(crossed, axis=0)[None]  # the earliest crossing (latching)
        at_first_t = np.take_along_axis(times, first, axis=0)[0]
        at_first_v = np.take_along_axis(potential, first, axis=0)[0]
        cross_t[m] = np.where(fires, at_first_t, _NEVER)
        cross_v[m] = np.where(fires, at_first_v, 0.0)
    return cross_t, cross_v


def _lateral_inhibition(cross_t: np.ndarray, cross_v: np.ndarray) -> np.ndarray:
    """§3: at each position only one map fires — earliest, then highest V, then lowest map.

    Returns the firing time map: ``cross_t`` where a neuron fires, ``+inf`` elsewhere.
    """
    crossed = np.isfinite(cross_t)
    earliest = cross_t.min(axis=0)  # +inf where no map crossed
    candidate = crossed & (cross_t == earliest[None])
    best_v = np.where(candidate, cross_v, -np.inf).max(axis=0)
    candidate &= cross_v == best_v[None]
    # The lowest map index among the remaining candidates: argmax finds the first True.
    winner = np.argmax(candidate, axis=0)
    fires = np.zeros_like(crossed)
    rows, cols = np.nonzero(candidate.any(axis=0))
    fires[winner[rows, cols], rows, cols] = True
    return np.where(fires, cross_t, _NEVER).astype(np.float32)


def _conv_layer(
    in_times: np.ndarray,
    weights: np.ndarray,
    thresholds: np.ndarray,
    padding: str,
    lateral_inhibition: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """A conv layer in inference mode: firing time map and float64 spike potentials."""
    cross_t, cross_v = _conv_crossings(in_times, weights, thresholds, padding)
    if lateral_inhibition:
        fire_t = _lateral_inhibition(cross_t, cross_v)
    else:
        fire_t = cross_t
    return fire_t, np.where(np.isfinite(fire_t), cross_v, 0.0)


def _pool_layer(in_times: np.ndarray, k: int, s: int, padding: str) -> np.ndarray:
    """§3 pooling: ``(m, q)`` fires at the first spike of map ``m`` in its block."""
    maps, height, width = in_times.shape
    out_h = _pool_out_size(padding, height, k, s)
    out_w = _pool_out_size(padding, width, k, s)
    out = np.full((maps, out_h, out_w), _NEVER, dtype=np.float32)
    for oy in range(out_h):
        for ox in range(out_w):
            # Block o*s … o*s + k - 1, clipped to the input (slicing clips).
            block = in_times[:, oy * s : oy * s + k, ox * s : ox * s + k]
            out[:, oy, ox] = block.min(axis=(1, 2))
    return out


def _spikes(fire_t: np.ndarray, fire_v: np.ndarray | None, t0: int) -> np.ndarray:
    """A time map as a spike array sorted by ``(t, map, row, col)``, with absolute times.

    ``fire_v`` (float64 potentials, ``None`` for pools) is reported rounded to float32.
    """
    maps, rows, cols = np.nonzero(np.isfinite(fire_t))
    out = np.zeros(len(maps), dtype=SPIKE_DTYPE)
    out["t"] = fire_t[maps, rows, cols].astype(np.uint64) + np.uint64(t0)
    out["map"] = maps
    out["row"] = rows
    out["col"] = cols
    if fire_v is not None:
        out["v"] = fire_v[maps, rows, cols].astype(np.float32)
    return np.sort(out, order=["t", "map", "row", "col"])


# ------------------------------------------------------------------------------------------------
# §4 conv1: Gabor kernels and PENT


def gabor_kernels(config: dict) -> np.ndarray:
    """§4: conv1's fixed Gabor kernels, ``(maps, 1, k, k)`` float32, each min–max scaled.

    Map ``m`` has orientation ``m·180°/maps`` (0°, 45°, 90°, 135° for 4 maps); kernel offsets
    ``x, y`` run over ``j - (k - 1)/2`` (``-2 … 2`` for k = 5), ``x`` along columns, ``y`` along
    rows.
    """
    k = int(config["conv1"]["kernel"])
    maps = int(config["conv1"]["maps"])
    sigma = float(config["gabor"]["sigma"])
    wavelength = float(config["gabor"]["wavelength"])
    gamma = float(config["gabor"]["gamma"])
    offsets = np.arange(k, dtype=np.float64) - (k - 1) / 2
    y, x = np.meshgrid(offsets, offsets, indexing="ij")  # y down the rows, x along the columns
    kernels = np.zeros((maps, 1, k, k), dtype=np.float32)
    for m in range(maps):
        theta = m * math.pi / maps
        xr = x * math.cos(theta) + y * math.sin(theta)
        yr = -x * math.sin(theta) + y * math.cos(theta)
        g = np.exp(-(xr**2 + gamma**2 * yr**2) / (2 * sigma**2)) * np.cos(
            2 * math.pi * xr / wavelength
        )
        span = g.max() - g.min()
        # A constant kernel (k = 1, say) has no range to scale: docs/model.md leaves it open;
        # like the engine, take all ones.
        if span > 0:
            w = ((g - g.min()) / span).astype(np.float32)
            # §4: scaled weights below 2**-21 are round-off of a zero; flush them to 0.
            kernels[m, 0] = np.where(w < np.float32(2.0**-21), np.float32(0), w)
        else:
            kernels[m, 0] = 1.0
    return kernels


def pent_thresholds(config: dict, conv1_weights: np.ndarray, n_in: int) -> np.ndarray:
    """§4: conv1's per-map thresholds θ1, float32, for ``N_in = n_in`` (PENT or static)."""
    maps = conv1_weights.shape[0]
    pent = config["pent"]
    if pent["mode"] == "static":
        return np.full(maps, np.float32(config["conv1"]["threshold"]), dtype=np.float32)
    area = float(config["width"] * config["height"])
    theta = np.zeros(maps, dtype=np.float32)
    for m in range(maps):
        k1 = float(np.sum(conv1_weights[m].astype(np.float64)))
        asked = float(pent["beta"]) * (n_in / area)
        if pent.get("max_density") is not None:
            asked = min(asked, float(pent["max_density"]))
        value = max(float(pent["theta_min"]), asked * k1)
        theta[m] = np.float32(value)  # computed in float64, rounded to float32
    return theta


# ------------------------------------------------------------------------------------------------
# The layers, stacked


def _thresholds(config: dict, weights: dict, layer: str, n_in: int) -> np.ndarray:
    if layer == "conv1":
        return pent_thresholds(config, weights["conv1"], n_in)
    maps = weights[layer].shape[0]
    return np.full(maps, np.float32(config[layer]["threshold"]), dtype=np.float32)


def _forward(
    config: dict,
    weights: dict,
    frame: np.ndarray,
    n_in: int,
    stop_before: str | None = None,
) -> tuple[dict, dict, dict]:
    """Run the layers in inference mode, up to (not including) ``stop_before``.

    Returns ``(times, potentials, thresholds)``: per layer run, its firing time map; per conv
    layer, its spike potentials and thresholds. ``times["input"]`` is the frame.
    """
    padding = config["padding"]
    times = {"input": frame}
    potentials: dict = {}
    thresholds: dict = {}
    previous = "input"
    for layer in LAYERS:
        if layer == stop_before:
            break
        if _layer_kind(layer) == "conv":
            thresholds[layer] = _thresholds(config, weights, layer, n_in)
            times[layer], potentials[layer] = _conv_layer(
                times[previous],
                np.asarray(weights[layer], dtype=np.float32),
                thresholds[layer],
                padding,
                bool(config[layer]["lateral_inhibition"]),
            )
        else:
            cfg = config[layer]
            times[layer] = _pool_layer(
                times[previous], int(cfg["kernel"]), int(cfg["stride"]), padding
            )
        previous = layer
    return times, potentials, thresholds


def _window_input(
    config: dict, t: np.ndarray, x: np.ndarray, y: np.ndarray, t0: int, n_in: int | None
) -> tuple[np.ndarray, int]:
    frame = time_embedded_frame(t, x, y, t0, int(config["width"]), int(config["height"]))
    if n_in is None:
        n_in = len(t)  # §4: the number of spikes given, whatever the estimate
    return frame, int(n_in)


# ------------------------------------------------------------------------------------------------
# §5 Detection


def receptive_field(config: dict, layer: str, row: int, col: int) -> tuple[int, int, int, int]:
    """§5: the sensor pixels a neuron of ``layer`` reads, ``(x0, y0, x1, y1)`` inclusive.

    The field is composed down through the layers with the geometry of §2; at each layer it is
    clipped to that layer's input (padding positions hold no neuron), so it is also clipped to the
    sensor. Bounds are pixel indices, both included.
    """
    padding = config["padding"]
    sizes = {"input": (int(config["height"]), int(config["width"]))}
    previous = "input"
    for name in LAYERS:
        h, w = sizes[previous]
        cfg = config[name]
        k = int(cfg["kernel"])
        if _layer_kind(name) == "conv":
            sizes[name] = (_conv_out_size(padding, h, k), _conv_out_size(padding, w, k))
        else:
            s = int(cfg["stride"])
            sizes[name] = (_pool_out_size(padding, h, k, s), _pool_out_size(padding, w, k, s))
        previous = name
    order = list(LAYERS[: LAYERS.index(layer) + 1])
    ranges = [(row, row), (col, col)]  # per axis, inclusive
    for index in range(len(order) - 1, -1, -1):
        name = order[index]
        below = order[index - 1] if index else "input"
        k = int(config[name]["kernel"])
        for axis in range(2):
            lo, hi = ranges[axis]
            if _layer_kind(name) == "conv":
                p_lo = _padding_lo(padding, k)
                lo, hi = lo - p_lo, hi - p_lo + k - 1
            else:
                s = int(config[name]["stride"])
                lo, hi = lo * s, hi * s + k - 1
            ranges[axis] = (max(lo, 0), min(hi, sizes[below][axis] - 1))
    (y0, y1), (x0, x1) = ranges
    return x0, y0, x1, y1


def _causes(
    config: dict, times: dict, layer: str, m: int, row: int, col: int, t: float, memo: dict
) -> frozenset:
    """§5: the input pixels ``(y, x)`` that caused neuron ``(m, row, col)`` of ``layer`` to
    fire at ``t`` (relative time).

    A conv neuron's causes are the inputs of its receptive field (every channel) that fired at or
    before ``t``; a pool neuron's are the neurons of its map ``m`` in its block that fired at
    ``t``, its first spikes. Pixels cause themselves. A neuron fires at most once per window, so
    its causes are memoized by neuron.
    """
    key = (layer, m, row, col)
    if key in memo:
        return memo[key]
    below = LAYERS[LAYERS.index(layer) - 1] if layer != "conv1" else "input"
    source = times[below]
    _, height, width = source.shape
    k = int(config[layer]["kernel"])
    out: set = set()
    if _layer_kind(layer) == "conv":
        p_lo = _padding_lo(config["padding"], k)
        ys = range(max(row - p_lo, 0), min(row - p_lo + k, height))
        xs = range(max(col - p_lo, 0), min(col - p_lo + k, width))
        for c in range(source.shape[0]):
            for iy in ys:
                for ix in xs:
                    tb = float(source[c, iy, ix])
                    if tb > t:
                        continue  # not fired, or fired later
                    if below == "input":
                        out.add((iy, ix))
                    else:
                        out |= _causes(config, times, below, c, iy, ix, tb, memo)
    else:
        s = int(config[layer]["stride"])
        for y in range(row * s, min(row * s + k, height)):
            for x in range(col * s, min(col * s + k, width)):
                if float(source[m, y, x]) == t:
                    out |= _causes(config, times, below, m, y, x, t, memo)
    memo[key] = frozenset(out)
    return memo[key]


def _detections(config: dict, times: dict, conv3: np.ndarray, t0: int) -> np.ndarray:
    out = np.zeros(len(conv3), dtype=DETECTION_DTYPE)
    memo: dict = {}
    for i, spike in enumerate(conv3):
        x0, y0, x1, y1 = receptive_field(config, "conv3", int(spike["row"]), int(spike["col"]))
        out[i]["t"] = spike["t"]
        out[i]["map"] = spike["map"]
        out[i]["row"] = spike["row"]
        out[i]["col"] = spike["col"]
        # The middle of the half-open field [x0, x1 + 1) × [y0, y1 + 1).
        out[i]["x"] = (x0 + x1 + 1) / 2
        out[i]["y"] = (y0 + y1 + 1) / 2
        t = float(np.float32(int(spike["t"]) - t0))
        m, row, col = int(spike["map"]), int(spike["row"]), int(spike["col"])
        pixels = _causes(config, times, "conv3", m, row, col, t, memo)
        if pixels:  # half-open: one past the largest x and y
            ys, xs = zip(*pixels, strict=True)
            out[i]["x0"], out[i]["x1"] = min(xs), max(xs) + 1
            out[i]["y0"], out[i]["y1"] = min(ys), max(ys) + 1
        else:  # degenerate: the receptive field itself
            out[i]["x0"], out[i]["x1"] = x0, x1 + 1
            out[i]["y0"], out[i]["y1"] = y0, y1 + 1
    return out


# ------------------------------------------------------------------------------------------------
# §7 One window in inference mode


def run_window(
    config: dict,
    weights: dict,
    t: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    t0: int,
    n_in: int | None = None,
) -> dict:
    """One window's input spikes through the whole network in inference mode (§1–§5, §7).

    Returns a dict with a spike array (:data:`SPIKE_DTYPE`) per layer name, ``"thresholds"``
    (conv1's θ1 per map, float32) and ``"detections"`` (:data:`DETECTION_DTYPE`). ``n_in``
    overrides ``N_in`` for PENT; by default it is the number of spikes given (``len(t)``).
    """
    frame, n_in = _window_input(config, t, x, y, t0, n_in)
    times, potentials, thresholds = _forward(config, weights, frame, n_in)
    result = {layer: _spikes(times[layer], potentials.get(layer), int(t0)) for layer in LAYERS}
    result["thresholds"] = thresholds["conv1"]
    result["detections"] = _detections(config, times, result["conv3"], int(t0))
    return result


# ------------------------------------------------------------------------------------------------
# §6 Training: winner-take-all and STDP


def _winners(cross_t: np.ndarray, cross_v: np.ndarray, k: int, radius: int, t0: int) -> np.ndarray:
    """§6 steps 1–3 over the trained layer's crossings (no lateral inhibition).

    Potentials are compared in float64 (§3); the winners report them rounded to float32.
    """
    maps, rows, cols = np.nonzero(np.isfinite(cross_t))
    # (t, V, map, row, col) of every neuron that crossed.
    crossed = [
        (float(cross_t[m, r, c]), float(cross_v[m, r, c]), int(m), int(r), int(c))
        for m, r, c in zip(maps, rows, cols, strict=True)
    ]
    # 1. Time ascending, potential descending, then map, row, col ascending.
    crossed.sort(key=lambda n: (n[0], -n[1], n[2], n[3], n[4]))
    winners: list[tuple[float, float, int, int, int]] = []
    for n in crossed:
        if len(winners) == k:  # 3. at most k winners
            break
        _, _, m, r, c = n
        if any(w[2] == m for w in winners):
            continue  # 2. intra-map: one winner per map
        if any(abs(r - w[3]) <= radius and abs(c - w[4]) <= radius for w in winners):
            continue  # 2. inter-map: inside the radius of an earlier winner
        winners.append(n)
    out = np.zeros(len(winners), dtype=SPIKE_DTYPE)
    for i, (t, v, m, r, c) in enumerate(winners):
        out[i] = (int(t) + t0, m, r, c, np.float32(v))
    return out


def _stdp_update(
    kernel: np.ndarray,
    in_times: np.ndarray,
    row: int,
    col: int,
    t_w: np.float32,
    p_lo: int,
    a_plus: np.float32,
    a_minus: np.float32,
) -> np.ndarray:
    """§6 STDP of one winner's kernel ``(C, k, k)``; returns the new kernel."""
    channels, k, _ = kernel.shape
    _, height, width = in_times.shape
    new = kernel.copy()
    one = np.float32(1)
    for c in range(channels):
        for dy in range(k):
            for dx in range(k):
                iy, ix = row - p_lo + dy, col - p_lo + dx
                inside = 0 <= iy < height and 0 <= ix < width  # padding never fires
                fired_before = inside and in_times[c, iy, ix] <= t_w
                a = a_plus if fired_before else a_minus
                w = np.float32(kernel[c, dy, dx])
                updated = np.float32(w + np.float32(np.float32(a * w) * np.float32(one - w)))
                new[c, dy, dx] = np.float32(min(max(updated, np.float32(0)), one))
    return new


def stdp_step(
    config: dict,
    weights: dict,
    layer: str,
    t: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    t0: int,
    n_in: int | None = None,
    a_plus: float | None = None,
    a_minus: float | None = None,
) -> tuple[np.ndarray, dict]:
    """§6: one training step of ``layer`` on one window.

    The layers below run in inference mode; ``layer`` runs without lateral inhibition; its
    winners are chosen, then each winner's kernel is updated by STDP. The learning rates default
    to the config's starting ``a_plus``/``a_minus``. Returns ``(winners, new_weights)``:
    winners in acceptance order (:data:`SPIKE_DTYPE`) and a new weights dict.
    """
    if layer not in CONV_LAYERS:
        raise ValueError(f"only a conv layer can be trained, not {layer!r}")
    frame, n_in = _window_input(config, t, x, y, t0, n_in)
    times, _, _ = _forward(config, weights, frame, n_in, stop_before=layer)
    below = LAYERS[LAYERS.index(layer) - 1] if layer != "conv1" else "input"
    in_times = times[below]
    kernels = np.asarray(weights[layer], dtype=np.float32)
    theta = _thresholds(config, weights, layer, n_in)
    cross_t, cross_v = _conv_crossings(in_times, kernels, theta, config["padding"])

    cfg = config[layer]
    winners = _winners(cross_t, cross_v, int(cfg["wta_k"]), int(cfg["wta_radius"]), int(t0))

    a_p = np.float32(config["stdp"]["a_plus"] if a_plus is None else a_plus)
    a_m = np.float32(config["stdp"]["a_minus"] if a_minus is None else a_minus)
    p_lo = _padding_lo(config["padding"], kernels.shape[2])
    new_kernels = kernels.copy()
    for w in winners:  # all winners are known before any update; their maps are distinct
        t_w = np.float32(int(w["t"]) - int(t0))
        m = int(w["map"])
        new_kernels[m] = _stdp_update(
            kernels[m], in_times, int(w["row"]), int(w["col"]), t_w, p_lo, a_p, a_m
        )
    new_weights = {name: np.array(value, dtype=np.float32) for name, value in weights.items()}
    new_weights[layer] = new_kernels
    return winners, new_weights


def learning_rates(config: dict, windows_seen: int) -> tuple[float, float]:
    """§6 schedule: ``(a_plus, a_minus)`` after ``windows_seen`` training windows.

    ``a_plus`` doubles every ``lr_every`` windows up to ``a_plus_max``; ``a_minus`` keeps the
    starting ratio, as ``a_minus₀ · (a_plus / a_plus₀)``, in float64.
    """
    stdp = config["stdp"]
    a_plus0, a_minus0 = float(stdp["a_plus"]), float(stdp["a_minus"])
    a_plus = a_plus0
    for _ in range(windows_seen // int(stdp["lr_every"])):
        a_plus = min(a_plus * 2, float(stdp["a_plus_max"]))
    return a_plus, a_minus0 * (a_plus / a_plus0)


def convergence(weights: np.ndarray) -> float:
    """§6: ``C = mean(w · (1 − w))`` over a layer's weights."""
    w = np.asarray(weights, dtype=np.float64)
    return float(np.mean(w * (1 - w)))
