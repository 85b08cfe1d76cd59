"""The pictures of the training and evaluation report, drawn with OpenCV and NumPy only.

Every function returns a BGR ``uint8`` image ``(h, w, 3)`` and writes nothing; :func:`write_png`
writes one. The pictures follow the paper's figures (Kirkland et al., 2019): learned features in
input-pixel space (Figs. 6–9), detections on an event frame (Fig. 10), PENT on and off on a noisy
window (Fig. 11), plus line charts, a confusion matrix and helpers to compose figures. Colours
follow :mod:`uavsnn.sim.preview`: a dark grey background, light text.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from typing import Any

import cv2
import numpy as np

from uavsnn._validate import check_int
from uavsnn.errors import ParameterError, ShapeError
from uavsnn.network import CONV_LAYERS, LAYERS, Network
from uavsnn.scenes.preview import write_png
from uavsnn.sim.preview import BACKGROUND

__all__ = [
    "confusion_image",
    "detections_image",
    "feature_evolution",
    "feature_grid",
    "feature_images",
    "hstack",
    "line_chart",
    "pent_comparison",
    "reconstruct_features",
    "roc_chart",
    "snr_chart",
    "spikes_image",
    "vstack",
    "write_png",
]

_FONT = cv2.FONT_HERSHEY_SIMPLEX
_TEXT = (220, 220, 220)
_DIM = (150, 150, 150)
_GRID = (62, 62, 62)
_DETECTION = (0, 220, 255)  # yellow: a detection box
_TRUTH = (0, 220, 0)  # green: the label box, as in uavsnn.scenes.contact_sheet
_TIME_MAP = cv2.COLORMAP_COOL  # early (cyan) -> late (magenta)
_PALETTE = [  # one colour per map or series (Tableau 10, BGR)
    (180, 119, 31), (14, 127, 255), (44, 160, 44), (40, 39, 214), (189, 103, 148),
    (75, 86, 140), (194, 119, 227), (127, 127, 127), (34, 189, 188), (207, 190, 23),
]  # fmt: skip
_GAP = 4


def _canvas(h: int, w: int) -> np.ndarray:
    return np.full((h, w, 3), BACKGROUND, dtype=np.uint8)


def _text(img: np.ndarray, s: str, at: tuple[int, int], size: float = 0.4, c: Any = _TEXT) -> None:
    cv2.putText(img, s, at, _FONT, size, c, 1, cv2.LINE_AA)


def _width(s: str, size: float = 0.4) -> int:
    return int(cv2.getTextSize(s, _FONT, size, 1)[0][0])


def _bar(text: str, width: int = 0, size: float = 0.5, colour: Any = _TEXT) -> np.ndarray:
    """A strip holding one line of text, at least ``width`` wide."""
    h = int(28 * size + 10)
    bar = _canvas(h, max(width, _width(text, size) + 12))
    _text(bar, text, (6, h - 7), size, colour)
    return bar


def _titled(img: np.ndarray, title: str) -> np.ndarray:
    return _join([_bar(title, img.shape[1]), img], 0, True) if title else img


def _join(images: Sequence[np.ndarray], pad: int, vertical: bool) -> np.ndarray:
    ims = []
    for i, a in enumerate(np.asarray(image) for image in images):
        if a.dtype != np.uint8:
            raise ParameterError(f"image {i} must be uint8, got {a.dtype}")
        a = cv2.cvtColor(a, cv2.COLOR_GRAY2BGR) if a.ndim == 2 and a.size else a
        if a.ndim != 3 or a.shape[2] != 3 or 0 in a.shape:
            raise ShapeError(f"image {i} must be (h, w, 3) or (h, w), got shape {a.shape}")
        ims.append(a.transpose(1, 0, 2) if vertical else a)
    if not ims:
        raise ParameterError("there are no images to join")
    pad = check_int("pad", pad, 0, 1000)
    h, x = max(im.shape[0] for im in ims) + 2 * pad, pad
    out = _canvas(h, sum(im.shape[1] + pad for im in ims) + pad)
    for im in ims:
        out[pad : pad + im.shape[0], x : x + im.shape[1]] = im
        x += im.shape[1] + pad
    return np.ascontiguousarray(out.transpose(1, 0, 2)) if vertical else out


def hstack(images: Sequence[np.ndarray], pad: int = 8) -> np.ndarray:
    """Images side by side, top-aligned, ``pad`` pixels of background between and around them."""
    return _join(images, pad, False)


def vstack(images: Sequence[np.ndarray], pad: int = 8) -> np.ndarray:
    """Images one above the other, left-aligned, ``pad`` pixels of background between and around."""
    return _join(images, pad, True)


# --- learned features (Figs. 6-9) -------------------------------------------------------------


def _through_pool(feature: np.ndarray, kernel: int, stride: int) -> np.ndarray:
    """A pool widens the field by ``(kernel - 1)`` positions of the grid below (``stride`` pixels
    apart) and keeps the feature in its middle, as SpykeTorch's ``get_deep_feature``."""
    size = np.array(feature.shape[1:])
    new = size + (kernel - 1) * stride
    r, c = new // 2 - size // 2
    out = np.zeros((len(feature), *new), dtype=np.float64)
    out[:, r : r + size[0], c : c + size[1]] = feature
    return out


def _transposed(weights: np.ndarray, feature: np.ndarray, stride: int) -> np.ndarray:
    """Transposed convolution: map ``m`` is the sum over channels ``c`` and kernel positions
    ``(i, j)`` of ``weights[m, c, i, j]`` times ``feature[c]`` placed at ``stride * (i, j)``."""
    maps, _, kh, kw = weights.shape
    h, w = feature.shape[1:]
    out = np.zeros((maps, h + (kh - 1) * stride, w + (kw - 1) * stride), dtype=np.float64)
    for i in range(kh):
        for j in range(kw):
            block = np.einsum("mc,chw->mhw", weights[:, :, i, j], feature)
            out[:, i * stride : i * stride + h, j * stride : j * stride + w] += block
    return out


def reconstruct_features(network: Network, layer: str) -> np.ndarray:
    """The features of conv layer ``layer`` in input-pixel space, ``(maps, H, W)`` float32, each
    map min-max scaled to ``[0, 1]`` (a constant map is all 1 if positive, else all 0).

    conv1's features are its kernels. A conv2 map's feature is the sum over input channels ``c``
    of its weight plane ``w[c]`` spread on the pool1 grid — weight ``(i, j)`` at ``pool1.stride *
    (i, j)`` pixels, inside a field that pool1's kernel widens — transposed-convolved with conv1's
    feature ``c``; conv3 likewise through pool2 and conv2's features (unscaled). For Table 1 the
    features are 5, 54 and 174 pixels wide (the receptive fields of the three layers).
    """
    if layer not in CONV_LAYERS:
        raise ParameterError(f"layer must be one of {', '.join(CONV_LAYERS)}, got {layer!r}")
    config = network.config
    feature = network.weights("conv1")[:, 0].astype(np.float64)
    stride = 1  # pixels between neighbouring positions of the current conv grid
    for conv, pool in (("conv2", "pool1"), ("conv3", "pool2"))[: CONV_LAYERS.index(layer)]:
        feature = _through_pool(feature, int(config[pool]["kernel"]), stride)
        stride *= int(config[pool]["stride"])
        feature = _transposed(network.weights(conv).astype(np.float64), feature, stride)
    lo = feature.min(axis=(1, 2), keepdims=True)
    span = feature.max(axis=(1, 2), keepdims=True) - lo
    scaled = np.where(span > 0, (feature - lo) / np.where(span > 0, span, 1), lo > 0)
    return scaled.astype(np.float32)


def _features(features: np.ndarray, what: str) -> np.ndarray:
    f = np.asarray(features, dtype=np.float32)
    if f.ndim != 3 or 0 in f.shape:
        raise ShapeError(f"{what} must be a non-empty (maps, H, W) array, got shape {f.shape}")
    if not np.isfinite(f).all():
        raise ParameterError(f"{what} must be finite")
    return f


def _tile(feature: np.ndarray, cell: int) -> np.ndarray:
    """One feature in grey, ``cell`` x ``cell``: nearest when enlarging, area when reducing."""
    grey = np.round(np.clip(feature, 0, 1) * 255).astype(np.uint8)
    shrink = cell < max(feature.shape)
    tile = cv2.resize(
        grey, (cell, cell), interpolation=cv2.INTER_AREA if shrink else cv2.INTER_NEAREST
    )
    return cv2.cvtColor(tile, cv2.COLOR_GRAY2BGR)


def feature_grid(
    features: np.ndarray, *, title: str, cols: int | None = None, cell: int = 48
) -> np.ndarray:
    """Feature maps ``(maps, H, W)`` in ``[0, 1]`` tiled in grey (white = strong weight), each
    ``cell`` x ``cell`` with its index above it, under a title bar. ``cols`` defaults to rows of
    equal length, at most ~1000 pixels wide."""
    f = _features(features, "features")
    cell = check_int("cell", cell, 4, 2000)
    n = len(f)
    if cols is None:
        most = max(1, 1000 // (cell + _GAP))
        cols = math.ceil(n / math.ceil(n / most))
    cols = min(n, check_int("cols", cols, 1, 10_000))
    rows, step = math.ceil(n / cols), cell + _GAP
    sheet = _canvas(rows * (step + 12) + _GAP, cols * step + _GAP)
    for i, m in enumerate(f):
        r, c = divmod(i, cols)
        x, y = _GAP + c * step, (r + 1) * (step + 12) - cell
        sheet[y : y + cell, x : x + cell] = _tile(m, cell)
        _text(sheet, str(i), (x, y - 3), 0.35, _DIM)
    return _titled(sheet, title)


def feature_images(network: Network) -> dict[str, np.ndarray]:
    """:func:`feature_grid` of each conv layer's :func:`reconstruct_features`, keyed by layer,
    each feature enlarged by an integer factor to at least 48 pixels."""
    out = {}
    for layer in CONV_LAYERS:
        f = reconstruct_features(network, layer)
        size = max(f.shape[1:])
        title = f"{layer}: {len(f)} features, {size} px"
        out[layer] = feature_grid(f, title=title, cell=size * math.ceil(48 / size))
    return out


def feature_evolution(
    snapshots: Sequence[tuple[str, np.ndarray]], *, title: str, cell: int = 40
) -> np.ndarray:
    """Features during training (the paper's Fig. 9): one row per ``(label, features)`` snapshot,
    its label on the left, each a one-row :func:`feature_grid` (maps in grey, indices above).
    All snapshots must have the same number of maps."""
    if len(snapshots) == 0:
        raise ParameterError("snapshots is empty")
    cell = check_int("cell", cell, 4, 2000)
    rows = [(str(label), _features(f, f"snapshot {label!r}")) for label, f in snapshots]
    if len({f.shape[0] for _, f in rows}) > 1:
        raise ShapeError(f"snapshots differ in map count: {[f.shape[0] for _, f in rows]}")
    left = max(_width(label) for label, _ in rows) + 12
    lines = []
    for label, f in rows:
        grid = feature_grid(f, title="", cols=len(f), cell=cell)
        head = _canvas(grid.shape[0], left)
        _text(head, label, (6, grid.shape[0] // 2 + 10))
        lines.append(_join([head, grid], 0, False))
    return _titled(_join(lines, 0, True), title)


# --- frames, detections and spikes (Figs. 10, 11) ---------------------------------------------


def _fields(array: Any, names: tuple[str, ...], what: str) -> np.ndarray:
    a = np.asarray(array)
    missing = [n for n in names if n not in (a.dtype.names or ())]
    if missing or a.ndim != 1:
        raise ParameterError(f"{what} must be a 1-D structured array with fields {names}")
    return a


def _frame(frame: np.ndarray, scale: int) -> tuple[np.ndarray, float]:
    """A time-embedded frame, silent pixels dark and active ones coloured by time; its span."""
    f = np.asarray(frame)
    if f.ndim != 2 or 0 in f.shape or f.dtype.kind not in "fiu":
        raise ShapeError(f"frame must be a non-empty (h, w) real array, got {f.dtype} {f.shape}")
    img = _canvas(*f.shape)
    active = np.isfinite(f)
    times = f[active].astype(np.float64)
    if times.size and times.min() < 0:
        raise ParameterError(f"frame times must be >= 0 (t - t0), got {times.min()}")
    span = float(times.max()) if times.size else 0.0
    level = np.round(times / max(span, 1e-9) * 255).astype(np.uint8)
    img[active] = cv2.applyColorMap(level.reshape(-1, 1), _TIME_MAP).reshape(-1, 3)
    return cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST), span


def _key_width(style: str) -> int:
    return 20 if style in ("line", "dashed line") else 10


def _keys(entries: Sequence[tuple[Any, str, str]], width: int, start: int = 6) -> np.ndarray:
    """A footer bar of legend entries ``(colour, label, "fill" | "box" | "dash" | "line" |
    "dashed line")`` from ``start``, at least ``width`` wide."""
    need = sum(12 + _key_width(st) + _width(s, 0.35) for _, s, st in entries)
    bar = _canvas(22, max(width, start + need))
    for colour, label, style in entries:
        wide = _key_width(style)
        if style == "dash":
            _dashed(bar, (start, 6), (start + 10, 16), colour)
        elif style in ("line", "dashed line"):
            _polyline(bar, np.array([[start, 11], [start + wide, 11]]), colour, style != "line")
        else:
            cv2.rectangle(bar, (start, 6), (start + 10, 16), colour, -1 if style == "fill" else 1)
        _text(bar, label, (start + wide + 4, 15), 0.35)
        start += 12 + wide + _width(label, 0.35)
    return bar


def _polyline(img: np.ndarray, pts: np.ndarray, colour: Any, dashed: bool) -> None:
    """A 2-pixel polyline through ``pts`` (``(n, 2)`` pixel columns and rows), solid or in
    dashes of 7 pixels with gaps of 5 that carry on from one segment to the next."""
    if not dashed:
        cv2.polylines(img, [pts.astype(np.int32)], False, colour, 2, cv2.LINE_AA)
        return
    walked = 0.0  # the length drawn so far, which sets where the next dash starts
    for a, b in zip(pts[:-1].astype(np.float64), pts[1:].astype(np.float64), strict=True):
        length = float(np.hypot(*(b - a)))
        s = (-walked) % 12.0  # the next dash's start along this segment
        while s < length:
            e = min(s + 7.0, length)
            p, q = a + (b - a) * s / length, a + (b - a) * e / length
            cv2.line(
                img,
                tuple(np.round(p).astype(int)),
                tuple(np.round(q).astype(int)),
                colour,
                2,
                cv2.LINE_AA,
            )
            s += 12.0
        walked += length


def _dashed(img: np.ndarray, p0: tuple[int, int], p1: tuple[int, int], colour: Any) -> None:
    (x0, y0), (x1, y1) = p0, p1
    for a in range(x0, x1 + 1, 6):
        for y in (y0, y1):
            cv2.line(img, (a, y), (min(a + 2, x1), y), colour, 1)
    for a in range(y0, y1 + 1, 6):
        for x in (x0, x1):
            cv2.line(img, (x, a), (x, min(a + 2, y1)), colour, 1)


def detections_image(
    frame: np.ndarray,
    detections: np.ndarray | None,
    *,
    truth_box: Sequence[float] | np.ndarray | None = None,
    title: str = "",
    scale: int = 3,
) -> np.ndarray:
    """A time-embedded frame (``t - t0`` µs, ``+inf`` where silent) scaled ``scale`` times:
    silent pixels dark, active ones cyan (early) to magenta (late); each detection's box (fields
    ``x0, y0, x1, y1`` half-open, ``map``) as a yellow rectangle just outside its pixels, with its
    map index; the ground-truth box ``(x0, y0, x1, y1)`` (skipped if None or NaN) dashed green.
    Below the frame, a key; above it a title bar when ``title`` is not empty (so with no title
    the frame is the top-left ``h*scale`` x ``w*scale`` block)."""
    scale = check_int("scale", scale, 1, 32)
    img, span = _frame(frame, scale)
    entries = []  # the key's entries: only what is drawn
    if detections is not None and len(detections):
        d = _fields(detections, ("x0", "y0", "x1", "y1", "map"), "detections")
        boxes = np.stack([d[k].astype(np.int64) for k in ("x0", "y0", "x1", "y1")], 1) * scale
        for x0, y0, x1, y1 in np.unique(boxes, axis=0):  # one box, labelled with all its maps
            maps = np.unique(d["map"][np.all(boxes == (x0, y0, x1, y1), axis=1)])
            cv2.rectangle(img, (x0 - 1, y0 - 1), (x1, y1), _DETECTION, 1)
            at = (int(x0) + 1, int(y0 - 4 if y0 > 12 else y0 + 11))
            _text(img, ",".join(str(m) for m in maps), at, 0.35, _DETECTION)
        entries.append((_DETECTION, "detection", "box"))
    if truth_box is not None:
        box = np.asarray(truth_box, dtype=np.float64).reshape(-1)
        if box.size != 4:
            raise ShapeError(f"truth_box must be (x0, y0, x1, y1), got {box.size} values")
        if np.isfinite(box).all():
            x0, y0 = (math.floor(v * scale) - 1 for v in box[:2])
            x1, y1 = (math.ceil(v * scale) for v in box[2:])
            _dashed(img, (x0, y0), (x1, y1), _TRUTH)
            entries.append((_TRUTH, "truth", "dash"))
    times = f"0-{span / 1e3:.3g} ms"
    key = _keys(entries, img.shape[1], start=78 + _width(times, 0.35))
    key[6:17, 6:66] = cv2.applyColorMap(np.linspace(0, 255, 60, dtype=np.uint8)[None], _TIME_MAP)
    _text(key, times, (70, 15), 0.35)
    return _titled(_join([img, key], 0, True), title)


def spikes_image(
    shape_hw: tuple[int, int],
    spikes: np.ndarray,
    *,
    stride: int = 1,
    title: str = "",
    scale: int = 3,
) -> np.ndarray:
    """A layer's spikes (fields ``row, col, map``) on a dark ``shape_hw`` canvas, each a
    ``stride`` x ``stride`` block at ``stride * (row, col)`` (1 for the layer's own grid) coloured
    by map, scaled ``scale`` times; a footer gives the count and the maps' colours."""
    h, w = (check_int("shape_hw", v, 1, 100_000) for v in tuple(shape_hw))
    stride, scale = check_int("stride", stride, 1, 1000), check_int("scale", scale, 1, 32)
    s = _fields(spikes, ("row", "col", "map"), "spikes")
    rows, cols = s["row"].astype(np.int64) * stride, s["col"].astype(np.int64) * stride
    if len(s) and (rows.max() >= h or cols.max() >= w):
        raise ShapeError(f"spikes reach ({rows.max()}, {cols.max()}), outside {h}x{w}")
    img = _canvas(h, w)
    maps = s["map"].astype(np.int64)
    colours = np.array(_PALETTE, dtype=np.uint8)[maps % len(_PALETTE)]
    for dy in range(stride):
        for dx in range(stride):
            ok = (rows + dy < h) & (cols + dx < w)
            img[rows[ok] + dy, cols[ok] + dx] = colours[ok]
    img = cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
    count = f"{len(s)} spikes"
    entries = [(_PALETTE[m % len(_PALETTE)], str(m), "fill") for m in np.unique(maps)[:10]]
    key = _keys(entries, img.shape[1], start=_width(count, 0.35) + 16)
    _text(key, count, (6, 15), 0.35)
    return _titled(_join([img, key], 0, True), title)


def pent_comparison(
    frame: np.ndarray, trace_pent: Any, trace_static: Any, *, title: str = ""
) -> np.ndarray:
    """The paper's Fig. 11: a (noisy) window's input frame, then conv1's spikes with PENT on and
    off (two :class:`~uavsnn.network.WindowTrace`), each with every layer's spike count and
    conv1's threshold range written under it."""
    f = np.asarray(frame)
    scale = min(3, max(1, 480 // f.shape[1])) if f.ndim == 2 and f.size else 1
    n_in = int(np.isfinite(f).sum())
    panels = [detections_image(f, None, title=f"input: {n_in} pixels", scale=scale)]
    for name, trace in (("PENT on", trace_pent), ("PENT off", trace_static)):
        if not all(hasattr(trace, a) for a in ("conv1", "counts", "thresholds")):
            raise ParameterError(f"the {name} trace must be a uavsnn.network.WindowTrace")
        counts = [f"{layer} {int(c)}" for layer, c in zip(LAYERS, trace.counts, strict=True)]
        th = np.asarray(trace.thresholds, dtype=np.float64)
        lines = ["  ".join(counts[:2]), "  ".join(counts[2:])]
        span = f"{th.min():.3g}" + (f"-{th.max():.3g}" if th.size and th.max() > th.min() else "")
        lines.append(f"conv1 threshold {span}" if th.size else "")
        image = spikes_image(f.shape, trace.conv1, title=f"conv1 spikes, {name}", scale=scale)
        panels.append(_join([image, *(_bar(s, 0, 0.4) for s in lines)], 0, True))
    return _titled(hstack(panels), title)


# --- charts -----------------------------------------------------------------------------------


def _span(v: np.ndarray) -> tuple[float, float]:
    lo, hi = float(v.min()), float(v.max())
    pad = (hi - lo) * 0.05 if hi > lo else max(abs(lo) * 0.1, 1.0)
    return lo - pad, hi + pad


def _ticks(lo: float, hi: float) -> tuple[np.ndarray, int]:
    """About 6 round ticks (1, 2 or 5 times a power of ten) in ``[lo, hi]``, and their decimals."""
    raw = (hi - lo) / 6
    mag = 10.0 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 5, 10) if m * mag >= raw * (1 - 1e-9))
    ticks = np.arange(math.ceil(lo / step - 1e-9), math.floor(hi / step + 1e-9) + 1) * step
    return np.where(np.abs(ticks) < step * 1e-9, 0.0, ticks), max(0, -math.floor(math.log10(step)))


def _legend(entries: Sequence[tuple[Any, str, str]], width: int) -> np.ndarray:
    """Legend entries in rows of :func:`_keys`, each as many as fit in ``width`` (one row when
    all fit), ``width`` wide."""
    rows: list[list[tuple[Any, str, str]]] = [[]]
    for entry in entries:
        if rows[-1] and _keys([*rows[-1], entry], 0).shape[1] > width:
            rows.append([])
        rows[-1].append(entry)
    return _join([_keys(row, width)[:, :width] for row in rows], 0, True)


def line_chart(
    x: Sequence[float] | np.ndarray,
    series: Mapping[str, Sequence[float] | np.ndarray],
    *,
    title: str,
    xlabel: str,
    ylabel: str,
    y_range: tuple[float, float] | None = None,
    size: tuple[int, int] = (640, 400),
    markers: bool = True,
    gaps: bool = True,
    intervals: Mapping[str, Sequence[tuple[float, float, float]]] | None = None,
    dashed: Collection[str] = (),
    colours: Mapping[str, int] | None = None,
    notes: Mapping[str, Sequence[tuple[float, float, str]]] | None = None,
) -> np.ndarray:
    """A line chart ``size = (width, height)``: one colour per series (legend below, in as many
    rows as it needs), round ticks with values, gridlines. Points are drawn in order of ``x``;
    a NaN is a gap (a point between gaps still gets its marker), or with ``gaps=False`` a value
    not measured at that ``x`` (the series' other points are joined: series measured at
    different x); ``y_range`` fixes the y axis, else it fits the data. ``intervals``: per
    series, ``(x, low, high)`` bars drawn in its colour (a vertical line with caps); where
    several series have bars, each series' are set a few pixels apart around their x, so bars
    at the same x stay apart. ``dashed``: the series drawn in dashes (then the legend shows
    each series' line); ``colours``: a series' index into the palette (default: its position,
    so two series can share a colour); ``notes``: per series, ``(x, y, text)`` written small
    in its colour above and left of that point, on a patch of background over the lines."""
    bars = {} if intervals is None else {str(k): list(v) for k, v in intervals.items()}
    for name, rows in bars.items():
        if name not in series:
            raise ParameterError(f"intervals name {name!r}, which is not a series")
        if any(len(r) != 3 or not np.isfinite(np.asarray(r, np.float64)).all() for r in rows):
            raise ParameterError(f"intervals of {name!r} must be finite (x, low, high) triples")
    texts = {} if notes is None else {str(k): list(v) for k, v in notes.items()}
    dashes = {str(k) for k in dashed}
    shades = {} if colours is None else {str(k): v for k, v in colours.items()}
    for what, names in (("dashed", dashes), ("colours", shades), ("notes", texts)):
        for name in names:
            if name not in series:
                raise ParameterError(f"{what} names {name!r}, which is not a series")
    for name, index in shades.items():
        check_int(f"colours[{name!r}]", index, 0, 10_000)
    for name, notes_of in texts.items():
        if any(
            len(r) != 3 or not np.isfinite(np.asarray(r[:2], np.float64)).all() for r in notes_of
        ):
            raise ParameterError(f"notes of {name!r} must be (x, y, text) with finite x and y")
    xs = np.asarray(x, dtype=np.float64)
    if xs.ndim != 1 or xs.size == 0 or not np.isfinite(xs).all():
        raise ParameterError(f"x must be a non-empty 1-D sequence of finite numbers, got {xs!r}")
    if len(series) == 0:
        raise ParameterError("series is empty: there is nothing to draw")
    ys = {str(k): np.asarray(v, dtype=np.float64) for k, v in series.items()}
    for name, v in ys.items():
        if v.shape != xs.shape:
            raise ShapeError(f"series {name!r} has shape {v.shape}, but x has {len(xs)} values")
    width, height = (
        check_int("size[0]", size[0], 200, 8000),
        check_int("size[1]", size[1], 150, 8000),
    )
    x0, x1 = _span(xs)
    finite = np.concatenate([v[np.isfinite(v)] for v in ys.values()])
    if y_range is not None:
        y0, y1 = (float(v) for v in y_range)
        if not (math.isfinite(y0) and math.isfinite(y1) and y0 < y1):
            raise ParameterError(f"y_range must be finite with low < high, got {y_range!r}")
    else:
        y0, y1 = _span(finite) if finite.size else (0.0, 1.0)
    (xt, xd), (yt, yd) = _ticks(x0, x1), _ticks(y0, y1)
    ylabels = [f"{v:.{yd}f}" for v in yt]
    left = max(_width(s, 0.35) for s in ylabels) + 30
    colour_of = {n: _PALETTE[shades.get(n, i) % len(_PALETTE)] for i, n in enumerate(ys)}
    legend = _legend(
        [
            (colour_of[n], n, ("dashed line" if n in dashes else "line") if dashes else "fill")
            for n in ys
        ],
        width,
    )
    pw, ph = width - left - 16, height - 36 - 42 - legend.shape[0]
    if pw < 40 or ph < 40:
        raise ParameterError(f"size {size} leaves no room for the plot")
    img = _canvas(height, width)
    plot = img[36 : 36 + ph, left : left + pw]  # a view: drawing here is clipped to the plot

    def px(vx: Any, vy: Any) -> np.ndarray:
        """Plot pixel ``(col, row)`` of data points (arrays or scalars), int32."""
        u = (np.asarray(vx, np.float64) - x0) / (x1 - x0) * (pw - 1)
        v = (y1 - np.asarray(vy, np.float64)) / (y1 - y0) * (ph - 1)
        return np.round(np.clip(np.stack([u, v], -1), -1e6, 1e6)).astype(np.int32)

    for t in xt:
        c, s = int(px(t, y0)[0]), f"{t:.{xd}f}"
        cv2.line(plot, (c, 0), (c, ph), _GRID, 1)
        _text(img, s, (left + c - _width(s, 0.35) // 2, 36 + ph + 14), 0.35)
    for t, s in zip(yt, ylabels, strict=True):
        r = int(px(x0, t)[1])
        cv2.line(plot, (0, r), (pw, r), _GRID, 1)
        _text(img, s, (left - 4 - _width(s, 0.35), 36 + r + 4), 0.35)
    cv2.rectangle(img, (left - 1, 35), (left + pw, 36 + ph), _DIM, 1)
    order = np.argsort(xs, kind="stable")
    barred = [name for name in ys if bars.get(name)]  # the series with bars, set apart in x
    for name, v in ys.items():
        colour, ok = colour_of[name], np.isfinite(v[order])
        pts = px(xs[order], np.where(ok, v[order], y0))
        # With gaps=False a series' NaNs are only "not measured at this x": its points are joined.
        runs = (
            np.split(np.arange(len(ok)), np.flatnonzero(np.diff(ok)) + 1)
            if gaps
            else [np.flatnonzero(ok)]
        )
        for run in runs:
            if run.size and ok[run[0]]:  # a run of finite points: a polyline, and markers
                _polyline(plot, pts[run], colour, name in dashes)
                for k in run if markers or len(run) == 1 else []:
                    cv2.circle(plot, (int(pts[k, 0]), int(pts[k, 1])), 3, colour, -1)
        for bx, low, high in bars.get(name, []):
            (c, top), (_, bottom) = px(bx, high), px(bx, low)
            c += 5 * barred.index(name) - 5 * (len(barred) - 1) // 2
            cv2.line(plot, (int(c), int(top)), (int(c), int(bottom)), colour, 1)
            for r in (top, bottom):
                cv2.line(plot, (int(c) - 4, int(r)), (int(c) + 4, int(r)), colour, 1)
    for name, notes_of in texts.items():  # over every line, each on a patch of background
        for nx, ny, note in notes_of:
            c, r = (int(v) for v in px(nx, ny))
            w, at = _width(str(note), 0.33), (c - _width(str(note), 0.33) - 5, r - 6)
            cv2.rectangle(plot, (at[0] - 2, at[1] - 10), (at[0] + w + 1, at[1] + 3), BACKGROUND, -1)
            _text(plot, str(note), at, 0.33, colour_of[name])
    _text(img, title, (left, 24), 0.5)
    _text(img, xlabel, (left + (pw - _width(xlabel)) // 2, 36 + ph + 32))
    label = np.rot90(_bar(ylabel, 0, 0.4)[:, : min(_width(ylabel) + 12, ph + 30)])
    top = max(0, 36 + (ph - label.shape[0]) // 2)
    img[top : top + label.shape[0], 2 : 2 + label.shape[1]] = label[: height - top]
    img[height - legend.shape[0] :] = legend[:, :width]
    return img


def confusion_image(
    matrix: Any, *, title: str, labels: tuple[str, str] = ("UAV", "not UAV")
) -> np.ndarray:
    """A 2x2 confusion matrix ``[[TP, FN], [FP, TN]]`` (rows: actual UAV / not; columns:
    predicted UAV / not): each cell shaded by its share of its row (dark = 0, blue = all), with
    its count and row percentage; the accuracy under it."""
    m = np.asarray(matrix, dtype=np.float64)
    if m.shape != (2, 2):
        raise ShapeError(f"matrix must be 2x2 [[TP, FN], [FP, TN]], got shape {m.shape}")
    if not np.isfinite(m).all() or (m < 0).any():
        raise ParameterError(f"matrix counts must be finite and >= 0, got {m.tolist()}")
    if len(labels) != 2:
        raise ParameterError(f"labels must be two names, got {labels!r}")
    rows = m.sum(axis=1, keepdims=True)
    share = np.divide(m, rows, out=np.zeros_like(m), where=rows > 0)
    heads = [f"actual {labels[0]}", f"actual {labels[1]}"]
    left, top, cw, ch = max(_width(s) for s in heads) + 16, 44, 150, 70
    img = _canvas(top + 2 * ch + 34, left + 2 * cw + 8)
    dark, full = np.array(BACKGROUND, float) + 16, np.array((200, 120, 30), float)
    for c, name in enumerate(labels):
        s = f"predicted {name}"
        _text(img, s, (left + c * cw + (cw - _width(s)) // 2, top - 10))
    for r in range(2):
        _text(img, heads[r], (8, top + r * ch + ch // 2 + 5))
        for c in range(2):
            x, y = left + c * cw, top + r * ch
            img[y + 1 : y + ch - 1, x + 1 : x + cw - 1] = dark + (full - dark) * share[r, c]
            count = f"{m[r, c]:.0f}" if m[r, c] == round(m[r, c]) else f"{m[r, c]:.1f}"
            pct = f"{100 * share[r, c]:.1f}% of row" if rows[r, 0] > 0 else "empty row"
            _text(img, count, (x + (cw - _width(count, 0.7)) // 2, y + 34), 0.7, (255, 255, 255))
            _text(img, pct, (x + (cw - _width(pct, 0.35)) // 2, y + 54), 0.35, (235, 235, 235))
    total = m.sum()
    accuracy = f"accuracy {100 * (m[0, 0] + m[1, 1]) / total:.1f}%" if total > 0 else "accuracy n/a"
    _text(img, f"{accuracy}   ({total:.0f} windows)", (left, top + 2 * ch + 22))
    return _titled(img, title)


def _noise_field(point: Any, name: str) -> Any:
    return point[name] if isinstance(point, Mapping) else getattr(point, name)


def _noise_accuracies(point: Any) -> tuple[float, float]:
    """A noise point's accuracy by the any-spike rule and with identification (NaN without)."""
    if isinstance(point, Mapping):  # NoisePoint.to_dict(), as in results.json's "noise"
        spike, ident = point["accuracy"], (point.get("identified") or {}).get("accuracy")
    else:  # a uavsnn.experiments.NoisePoint
        spike = point.evaluation.accuracy
        ident = (point.identified or {}).get("identified", {}).get("accuracy")
    return float(spike), float("nan") if ident is None else float(ident)


_MODE_NAMES = {"pent": "PENT", "static": "static"}


def snr_chart(
    noise: Sequence[Any],
    *,
    paper: Mapping[float, float] | None = None,
    title: str = "accuracy against SNR; the paper's Table 3 at our SNR of its noise share",
    size: tuple[int, int] = (760, 460),
) -> np.ndarray:
    """Accuracy against the windows' median SNR of each noise share (SPEC §5, the paper's
    Table 3): per thresholding mode (PENT, static) one colour, the any-spike rule solid and
    detection + identification dashed (where the points have it); the paper's accuracy at each
    share of ``paper`` (``{share: accuracy}``, default
    :data:`uavsnn.experiments.PAPER_TABLE3_BY_SHARE`) drawn at our median SNR of that same
    share and labelled with it, since the paper's own SNR labels cannot all come from one
    signal. ``noise``: :class:`~uavsnn.experiments.NoisePoint` s or their ``to_dict()`` (as
    results.json's ``"noise"``); points without noise (no finite SNR) are left out, as are the
    paper's shares that ``noise`` lacks."""
    if paper is None:
        from uavsnn.experiments import PAPER_TABLE3_BY_SHARE

        paper = PAPER_TABLE3_BY_SHARE
    rows = []
    for point in noise:
        snr = _noise_field(point, "snr_db")
        if snr is not None and math.isfinite(float(snr)):
            rows.append(
                (
                    float(_noise_field(point, "fraction")),
                    float(snr),
                    str(_noise_field(point, "mode")),
                    *_noise_accuracies(point),
                )
            )
    if not rows:
        raise ParameterError("noise has no point with added noise (a finite SNR) to draw")
    shares = sorted({r[0] for r in rows})
    at = {f: float(np.median([r[1] for r in rows if r[0] == f])) for f in shares}
    x = [at[f] for f in shares]
    series: dict[str, list[float]] = {}
    dashed, colours = [], {}
    for i, mode in enumerate(dict.fromkeys(r[2] for r in rows)):
        name = _MODE_NAMES.get(mode, mode)
        by_share = {r[0]: r[3:] for r in rows if r[2] == mode}
        for rule, k in (("any spike", 0), ("+ identification", 1)):
            values = [by_share[f][k] if f in by_share else math.nan for f in shares]
            if k == 0 or np.isfinite(values).any():
                series[f"{name} {rule}"] = values
                colours[f"{name} {rule}"] = i
                if k == 1:
                    dashed.append(f"{name} {rule}")
    matched = {float(f): float(a) for f, a in paper.items() if float(f) in at}
    notes = {}
    if matched:
        label = "paper (Table 3) by share"
        series[label] = [matched.get(f, math.nan) for f in shares]
        colours[label] = max(2, len(set(colours.values())))  # green beside PENT and static
        notes[label] = [(at[f], a, f"{100 * f:g} %") for f, a in matched.items()]
    return line_chart(
        x,
        series,
        title=title,
        xlabel="median SNR of the noisy test windows at each noise share (dB)",
        ylabel="accuracy",
        y_range=(0.0, 1.0),
        size=size,
        gaps=False,
        dashed=dashed,
        colours=colours,
        notes=notes,
    )


def roc_chart(
    rocs: dict[str, dict[str, Any]],
    title: str,
    points: Mapping[str, Sequence[Mapping[str, Any]]] | None = None,
) -> np.ndarray:
    """The ROC curves of :func:`uavsnn.evaluation.identification_figures` outputs
    (``{name: figures["roc"]}``) as one chart: detection rate against false-alarm rate.
    ``points``: per curve, its points read off the ROC (``figures["at_false_alarm"]``), each
    drawn as its detection's 95 % interval over the recordings at its false-alarm rate."""
    # One x axis, the union of the curves' false-alarm points; each curve is joined over its
    # own points (a NaN is a point it was not measured at), its best detection at each.
    xs = np.unique(np.concatenate([np.asarray(r["false_alarm"]) for r in rocs.values()]))
    series = {}
    for name, roc in rocs.items():
        y = np.full(xs.shape, np.nan)
        at = np.searchsorted(xs, np.asarray(roc["false_alarm"], dtype=np.float64))
        np.fmax.at(y, at, np.asarray(roc["detection"], dtype=np.float64))
        series[name] = y
    return line_chart(
        xs,
        series,
        title=title,
        xlabel="UAV-free windows alarming",
        ylabel="UAV windows detected",
        y_range=(0.0, 1.0),
        markers=False,
        gaps=False,
        intervals={
            name: [
                (
                    float(p["false_alarm_rate"]),
                    float(p["detection_interval"][0]),
                    float(p["detection_interval"][1]),
                )
                for p in at
                if _drawn(p.get("detection_interval"))
            ]
            for name, at in (points or {}).items()
            if name in rocs
        },
    )


def _drawn(interval: Sequence[float] | None) -> bool:
    """Whether a figure's interval can be drawn: given, and not NaN (drawn from too few
    recordings, :data:`uavsnn.evaluation.MIN_INTERVAL_RECORDINGS`)."""
    return interval is not None and not any(math.isnan(v) for v in interval)
