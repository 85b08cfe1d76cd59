"""The report's pictures (uavsnn.pictures): feature reconstruction geometry, what lands where in
each picture, and typed errors for bad input."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import cv2
import numpy as np
import pytest

import uavsnn
from uavsnn import pictures
from uavsnn.network import DETECTION_DTYPE, SPIKE_DTYPE, WINDOW_DETECTION_DTYPE, Network

YELLOW = np.array([0, 220, 255], np.uint8)  # detection boxes
GREEN = np.array([0, 220, 0], np.uint8)  # the ground-truth box
BACKGROUND = np.array([32, 32, 32], np.uint8)


def small_net(**changes: Any) -> Network:
    """Table 1's layers on a 48x36 sensor."""
    return Network(config={"width": 48, "height": 36, **changes}, seed=0)


def is_bgr(img: np.ndarray) -> bool:
    return img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3


def colour_mask(img: np.ndarray, colour: np.ndarray) -> np.ndarray:
    return np.all(img == colour, axis=2)


# ------------------------------------------------------------------------ features


def test_conv1_features_are_the_normalised_kernels() -> None:
    net = small_net()
    w = net.weights("conv1")[:, 0].astype(np.float64)
    lo, hi = w.min(axis=(1, 2), keepdims=True), w.max(axis=(1, 2), keepdims=True)
    got = pictures.reconstruct_features(net, "conv1")
    assert got.dtype == np.float32 and got.shape == (4, 5, 5)
    np.testing.assert_allclose(got, (w - lo) / (hi - lo), atol=1e-6)


@pytest.mark.parametrize(("c", "i", "j"), [(0, 0, 0), (2, 3, 7), (3, 9, 9)])
def test_conv2_single_weight_is_conv1_feature_at_pool_stride(c: int, i: int, j: int) -> None:
    net = small_net()
    w2 = net.weights("conv2")
    w2[5] = 0
    w2[5, c, i, j] = 1
    net.set_weights("conv2", w2)
    conv1 = pictures.reconstruct_features(net, "conv1")
    got = pictures.reconstruct_features(net, "conv2")
    # conv1 field 5 px; pool1 (kernel 5 over the 1-px conv1 grid) widens it to 9 px with the
    # feature in the middle (offset 2); conv2's 10 weights sit 5 px apart: 9 + 9 * 5 = 54 px.
    assert got.shape == (20, 54, 54)
    expected = np.zeros((54, 54), np.float32)
    expected[5 * i + 2 : 5 * i + 7, 5 * j + 2 : 5 * j + 7] = conv1[c]
    np.testing.assert_allclose(got[5], expected, atol=1e-6)


def test_conv3_single_weight_is_conv2_feature_at_pool_strides() -> None:
    net = small_net()
    w3 = net.weights("conv3")
    w3[2] = 0
    w3[2, 7, 1, 3] = 1
    net.set_weights("conv3", w3)
    conv2 = pictures.reconstruct_features(net, "conv2")
    got = pictures.reconstruct_features(net, "conv3")
    # pool2 widens conv2's 54-px field by 4 positions 5 px apart (74 px, feature at offset 10);
    # conv3's weights sit 5 * 5 = 25 px apart: 74 + 4 * 25 = 174 px, conv3's receptive field.
    assert got.shape == (10, 174, 174)
    expected = np.zeros((174, 174), np.float32)
    expected[25 + 10 : 25 + 64, 75 + 10 : 75 + 64] = conv2[7]
    np.testing.assert_allclose(got[2], expected, atol=1e-6)


def test_pool_geometry_follows_the_config() -> None:
    net = small_net(pool1={"kernel": 3, "stride": 2}, conv2={"kernel": 4, "maps": 3})
    w2 = np.zeros((3, 4, 4, 4), np.float32)
    w2[0, 1, 2, 1] = 1
    net.set_weights("conv2", w2)
    got = pictures.reconstruct_features(net, "conv2")
    # 5 + 2 = 7 px after pool1 (offset 1), then 7 + 3 * 2 = 13 px; weight (2, 1) at (4, 2).
    assert got.shape == (3, 13, 13)
    expected = np.zeros((13, 13), np.float32)
    expected[5:10, 3:8] = pictures.reconstruct_features(net, "conv1")[1]
    np.testing.assert_allclose(got[0], expected, atol=1e-6)
    assert np.all(got[1] == 0)  # an all-zero map stays zero, not NaN


def test_feature_images_and_grid() -> None:
    images = pictures.feature_images(small_net())
    assert set(images) == {"conv1", "conv2", "conv3"}
    assert all(is_bgr(img) for img in images.values())
    f = np.zeros((3, 6, 6), np.float32)
    f[1] = 1.0
    grid = pictures.feature_grid(f, title="t", cell=30)
    assert is_bgr(grid)
    # Only the all-ones map is pure white (text is light grey): exactly one cell of it.
    assert colour_mask(grid, np.array([255, 255, 255], np.uint8)).sum() == 30 * 30
    assert pictures.feature_grid(f, title="t", cell=30, cols=1).shape[0] > grid.shape[0]


def test_feature_evolution_has_a_row_per_snapshot() -> None:
    zeros, ones = np.zeros((5, 8, 8), np.float32), np.ones((5, 8, 8), np.float32)
    one = pictures.feature_evolution([("0 windows", zeros)], title="", cell=20)
    two = pictures.feature_evolution(
        [("0 windows", zeros), ("500 windows", ones)], title="", cell=20
    )
    assert is_bgr(two) and two.shape[0] == 2 * one.shape[0]
    white = colour_mask(two, np.array([255, 255, 255], np.uint8))
    assert white.sum() == 5 * 20 * 20 and not white[: one.shape[0]].any()  # the second row
    titled = pictures.feature_evolution([("0 windows", zeros)], title="conv2", cell=20)
    assert titled.shape[0] > one.shape[0]
    with pytest.raises(uavsnn.ShapeError, match="map count"):
        pictures.feature_evolution([("a", ones), ("b", ones[:3])], title="x")


# ------------------------------------------------------------------------ frames


def test_detections_image_draws_boxes_on_their_border() -> None:
    frame = np.full((36, 48), np.inf, np.float32)
    frame[2, 2], frame[30, 40] = 0.0, 10_000.0  # earliest and latest
    d = np.zeros(1, DETECTION_DTYPE)
    d["x0"], d["y0"], d["x1"], d["y1"], d["map"] = 10, 5, 20, 15, 3
    img = pictures.detections_image(frame, d, truth_box=(30.0, 20.0, 40.0, 30.0), scale=3)
    assert is_bgr(img) and img.shape[1] >= 48 * 3 and img.shape[0] > 36 * 3
    yellow = colour_mask(img, YELLOW)
    # The rectangle lies just outside the box's pixels [30, 60) x [15, 45) after scaling.
    assert yellow[14, 29:61].all() and yellow[45, 29:61].all()
    assert yellow[14:46, 29].all() and yellow[14:46, 60].all()
    assert not yellow[18:42, 33:57].any()
    green = colour_mask(img, GREEN)
    assert green[59, 89:121].sum() > 8 and green[90, 89:121].sum() > 8  # dashed
    assert not green[64:86, 94:116].any()
    # Silent pixels dark, the earliest and latest active pixels coloured differently.
    assert (img[20, 120] == BACKGROUND).all()
    early, late = img[2 * 3 + 1, 2 * 3 + 1], img[30 * 3 + 1, 40 * 3 + 1]
    assert not (early == BACKGROUND).all() and not (early == late).all()
    # Window detections (with a window field) draw the same; a title adds a bar on top.
    w = np.zeros(1, WINDOW_DETECTION_DTYPE)
    for name in DETECTION_DTYPE.names or ():
        w[name] = d[name]
    np.testing.assert_array_equal(
        pictures.detections_image(frame, w, truth_box=None),
        pictures.detections_image(frame, d, truth_box=[np.nan] * 4),
    )
    assert pictures.detections_image(frame, None, title="fig").shape[0] > img.shape[0]


def test_spikes_image_places_and_colours_spikes() -> None:
    s = np.zeros(2, SPIKE_DTYPE)
    s["row"], s["col"], s["map"] = [1, 4], [2, 0], [0, 1]
    img = pictures.spikes_image((10, 12), s, stride=2, scale=1)
    assert is_bgr(img) and img.shape[1] >= 12 and img.shape[0] > 10
    a, b = img[2:4, 4:6].reshape(-1, 3), img[8:10, 0:2].reshape(-1, 3)
    assert (a == a[0]).all() and (b == b[0]).all() and not (a[0] == b[0]).all()
    assert not (a[0] == BACKGROUND).all() and not (b[0] == BACKGROUND).all()
    lit = np.any(img[:10, :12] != BACKGROUND, axis=2)
    assert lit.sum() == 8
    with pytest.raises(uavsnn.ShapeError, match="outside"):
        pictures.spikes_image((10, 12), s, stride=3)


def test_pent_comparison_shows_both_traces() -> None:
    rng = np.random.default_rng(1)
    n = 300
    pixels = rng.choice(48 * 36, n, replace=False)
    x, y = (pixels % 48).astype(np.uint16), (pixels // 48).astype(np.uint16)
    t = np.sort(rng.integers(0, 20_000, n)).astype(np.uint64)
    pent = small_net().run_window(t, x, y, 0)
    static = small_net(pent={"mode": "static"}).run_window(t, x, y, 0)
    frame = np.full((36, 48), np.inf, np.float32)
    frame[y, x] = t
    img = pictures.pent_comparison(frame, pent, static, title="Fig. 11")
    assert is_bgr(img) and img.shape[1] > 3 * 48 * 3
    swapped = pictures.pent_comparison(frame, static, pent, title="Fig. 11")
    assert img.shape != swapped.shape or not np.array_equal(img, swapped)
    with pytest.raises(uavsnn.ParameterError, match="WindowTrace"):
        pictures.pent_comparison(frame, pent, object())


# ------------------------------------------------------------------------ charts


def first_series_rows(img: np.ndarray) -> tuple[float, float]:
    """Mean row of the first series' colour in its leftmost and rightmost columns (plot only:
    the legend is the bottom 22 rows)."""
    mask = colour_mask(img[:-30], np.array([180, 119, 31], np.uint8))
    cols = np.flatnonzero(mask.any(axis=0))
    return float(np.flatnonzero(mask[:, cols[0]]).mean()), float(
        np.flatnonzero(mask[:, cols[-1]]).mean()
    )


def test_line_chart_puts_higher_values_higher() -> None:
    kw: dict[str, Any] = {"title": "t", "xlabel": "x", "ylabel": "y"}
    left, right = first_series_rows(pictures.line_chart([0, 1], {"a": [0.2, 0.9]}, **kw))
    assert right < left - 50
    left, right = first_series_rows(pictures.line_chart([0, 1], {"a": [0.9, 0.2]}, **kw))
    assert left < right - 50


def test_line_chart_sorts_x_and_handles_edge_cases() -> None:
    kw: dict[str, Any] = {"title": "acc", "xlabel": "SNR (dB)", "ylabel": "accuracy"}
    x, y = [-15.0, 5.0, -5.0, 20.0], [0.5, 0.8, 0.6, 0.9]
    order = np.argsort(x)
    shuffled = pictures.line_chart(x, {"ours": y, "paper": [0.4] * 4}, **kw)
    ordered = pictures.line_chart(
        np.array(x)[order], {"ours": np.array(y)[order], "paper": [0.4] * 4}, **kw
    )
    np.testing.assert_array_equal(shuffled, ordered)
    assert shuffled.shape == (400, 640, 3)
    blue = np.array([180, 119, 31], np.uint8)
    gap = pictures.line_chart(x, {"ours": [0.5, np.nan, 0.6, 0.9]}, **kw, markers=False)
    full = pictures.line_chart(x, {"ours": y}, **kw, markers=False)
    assert 0 < colour_mask(gap, blue).sum() < colour_mask(full, blue).sum()
    single = pictures.line_chart([3.0], {"C": [0.25]}, **kw, markers=False, size=(300, 200))
    assert single.shape == (200, 300, 3) and colour_mask(single[:-30], blue).any()
    const = pictures.line_chart([0, 1, 2], {"C": [1.0, 1.0, 1.0]}, **kw, y_range=(0, 2))
    assert colour_mask(const[:-30], blue).any()
    all_nan = pictures.line_chart([0, 1], {"C": [np.nan, np.nan]}, **kw)
    assert not colour_mask(all_nan[:-30], blue).any()


def test_line_chart_draws_interval_bars_in_their_series_colour() -> None:
    kw: dict[str, Any] = {"title": "t", "xlabel": "x", "ylabel": "y", "y_range": (0, 1)}
    blue = np.array([180, 119, 31], np.uint8)
    plain = pictures.line_chart([0, 1], {"a": [0.5, 0.5], "b": [0.1, 0.1]}, **kw)
    barred = pictures.line_chart(
        [0, 1], {"a": [0.5, 0.5], "b": [0.1, 0.1]}, **kw, intervals={"a": [(0.5, 0.2, 0.9)]}
    )
    new = colour_mask(barred[:-30], blue) & ~colour_mask(plain[:-30], blue)
    rows, cols = np.nonzero(new)
    # A vertical bar: about 0.7 of the plot's height tall, in one column bar its caps, in the
    # middle of the x axis.
    assert rows.max() - rows.min() > 0.6 * (barred.shape[0] - 150)
    column = np.bincount(cols).argmax()
    assert abs(column - barred.shape[1] / 2) < 60 and (cols == column).sum() > 100
    for bad, match in (
        ({"c": [(0.5, 0.2, 0.9)]}, "not a series"),
        ({"a": [(0.5, 0.2)]}, "triples"),
        ({"a": [(0.5, np.nan, 0.9)]}, "triples"),
    ):
        with pytest.raises(uavsnn.ParameterError, match=match):
            pictures.line_chart([0, 1], {"a": [0.5, 0.5]}, **kw, intervals=bad)


def test_confusion_image_depends_on_the_counts() -> None:
    a = pictures.confusion_image([[90, 10], [5, 95]], title="test")
    b = pictures.confusion_image([[10, 90], [5, 95]], title="test")
    assert is_bgr(a) and a.shape == b.shape and not np.array_equal(a, b)
    assert is_bgr(pictures.confusion_image(np.zeros((2, 2)), title="empty"))


def test_hstack_and_vstack_pad_and_align() -> None:
    a = np.full((10, 20, 3), 200, np.uint8)
    b = np.full((30, 5), 100, np.uint8)  # grey is accepted
    h = pictures.hstack([a, b], pad=8)
    assert h.shape == (30 + 16, 20 + 5 + 24, 3)
    assert (h[8:18, 8:28] == 200).all() and (h[8:38, 36:41] == 100).all()
    assert (h[20, 10] == BACKGROUND).all()
    v = pictures.vstack([a, b], pad=2)
    assert v.shape == (10 + 30 + 6, 20 + 4, 3)
    assert (v[2:12, 2:22] == 200).all() and (v[14:44, 2:7] == 100).all()


def test_write_png_round_trips(tmp_path: Path) -> None:
    img = pictures.confusion_image([[1, 2], [3, 4]], title="x")
    path = pictures.write_png(tmp_path / "c.png", img)
    np.testing.assert_array_equal(cv2.imread(str(path)), img)


# ------------------------------------------------------------------------ errors


CHART: dict[str, Any] = {"title": "", "xlabel": "", "ylabel": ""}
EMPTY = np.zeros((4, 4))
BAD_INPUT: dict[str, tuple[Any, type[Exception], str]] = {
    "pool layer": (
        lambda: pictures.reconstruct_features(small_net(), "pool1"),
        uavsnn.ParameterError,
        "layer",
    ),
    "2-D features": (lambda: pictures.feature_grid(EMPTY, title="x"), uavsnn.ShapeError, "maps"),
    "cell 0": (
        lambda: pictures.feature_grid(EMPTY[None], title="x", cell=0),
        uavsnn.ParameterError,
        "cell",
    ),
    "no snapshots": (
        lambda: pictures.feature_evolution([], title="x"),
        uavsnn.ParameterError,
        "empty",
    ),
    "1-D frame": (lambda: pictures.detections_image(np.zeros(5), None), uavsnn.ShapeError, "frame"),
    "plain detections": (
        lambda: pictures.detections_image(EMPTY, np.zeros(3)),
        uavsnn.ParameterError,
        "fields",
    ),
    "short truth box": (
        lambda: pictures.detections_image(EMPTY, None, truth_box=(1, 2)),
        uavsnn.ShapeError,
        "truth_box",
    ),
    "scale 0": (
        lambda: pictures.detections_image(EMPTY, None, scale=0),
        uavsnn.ParameterError,
        "scale",
    ),
    "spikes without rows": (
        lambda: pictures.spikes_image((4, 4), np.zeros(2, [("x", "u2")])),
        uavsnn.ParameterError,
        "row",
    ),
    "empty x": (
        lambda: pictures.line_chart([], {"a": []}, **CHART),
        uavsnn.ParameterError,
        "x must",
    ),
    "no series": (lambda: pictures.line_chart([1], {}, **CHART), uavsnn.ParameterError, "series"),
    "short series": (
        lambda: pictures.line_chart([1, 2], {"a": [1]}, **CHART),
        uavsnn.ShapeError,
        "'a'",
    ),
    "inverted y_range": (
        lambda: pictures.line_chart([1], {"a": [1]}, **CHART, y_range=(1, 0)),
        uavsnn.ParameterError,
        "y_range",
    ),
    "dashed unknown series": (
        lambda: pictures.line_chart([1], {"a": [1]}, **CHART, dashed=["b"]),
        uavsnn.ParameterError,
        "dashed names 'b'",
    ),
    "colours unknown series": (
        lambda: pictures.line_chart([1], {"a": [1]}, **CHART, colours={"b": 0}),
        uavsnn.ParameterError,
        "colours names 'b'",
    ),
    "note without y": (
        lambda: pictures.line_chart([1], {"a": [1]}, **CHART, notes={"a": [(1.0, "x")]}),
        uavsnn.ParameterError,
        "notes of 'a'",
    ),
    "noise without noise": (
        lambda: pictures.snr_chart([{"fraction": 0.0, "snr_db": None, "mode": "pent"}]),
        uavsnn.ParameterError,
        "finite SNR",
    ),
    "3x3 matrix": (
        lambda: pictures.confusion_image(np.zeros((3, 3)), title=""),
        uavsnn.ShapeError,
        "2x2",
    ),
    "negative count": (
        lambda: pictures.confusion_image([[1, -1], [0, 0]], title=""),
        uavsnn.ParameterError,
        ">= 0",
    ),
    "no images": (lambda: pictures.hstack([]), uavsnn.ParameterError, "no images"),
    "float image": (
        lambda: pictures.vstack([np.zeros((2, 2, 3), np.float32)]),
        uavsnn.ParameterError,
        "uint8",
    ),
    "negative pad": (
        lambda: pictures.hstack([np.zeros((2, 2, 3), np.uint8)], pad=-1),
        uavsnn.ParameterError,
        "pad",
    ),
}


@pytest.mark.parametrize("case", list(BAD_INPUT))
def test_bad_input_raises_typed_errors(case: str) -> None:
    call, error, match = BAD_INPUT[case]
    with pytest.raises(error, match=match):
        call()


def test_line_chart_joins_series_measured_at_other_x_without_gaps() -> None:
    nan = float("nan")
    series = {"a": [0.2, nan, 0.8], "b": [nan, 0.5, nan]}
    x = [0.0, 1.0, 2.0]
    with_gaps = pictures.line_chart(
        x, series, title="t", xlabel="x", ylabel="y", y_range=(0, 1), markers=False
    )
    joined = pictures.line_chart(
        x, series, title="t", xlabel="x", ylabel="y", y_range=(0, 1), markers=False, gaps=False
    )
    # with gaps, "a" has no line between its two points; joined, the pixels between them change
    assert (joined != with_gaps).any()
    blue = np.array(joined[:, :, 0] == 180) & (joined[:, :, 1] == 119) & (joined[:, :, 2] == 31)
    assert (
        blue.sum()
        > (
            (with_gaps[:, :, 0] == 180) & (with_gaps[:, :, 1] == 119) & (with_gaps[:, :, 2] == 31)
        ).sum()
    )


# ------------------------------------------------------------------------ accuracy against SNR

BLUE = np.array([180, 119, 31], np.uint8)  # the first mode (PENT)
ORANGE = np.array([14, 127, 255], np.uint8)  # the second (static)
PAPER_GREEN = np.array([44, 160, 44], np.uint8)  # the paper


def noise_point(
    fraction: float, snr: float | None, mode: str, accuracy: float, identified: float | None
) -> dict[str, Any]:
    """A noise point as results.json's ``"noise"`` holds it (NoisePoint.to_dict())."""
    point: dict[str, Any] = {"fraction": fraction, "snr_db": snr, "mode": mode}
    point["accuracy"] = accuracy
    if identified is not None:
        point["identified"] = {"accuracy": identified, "confusion": [[1, 0], [0, 1]]}
    return point


def test_snr_chart_puts_the_papers_points_at_our_snr_of_the_same_share() -> None:
    # Our shares 0.5 % and 5 % sit at 10 dB and 0 dB; the paper's figures for those shares must
    # be drawn there (SPEC §5), not at its own labels (23 and -15 dB), which lie outside ours.
    noise = [
        noise_point(0.0, None, "pent", 0.5, None),  # no noise: no SNR, left out
        noise_point(0.005, 10.0, "pent", 0.5, None),
        noise_point(0.05, 0.0, "pent", 0.5, None),
    ]
    chart = pictures.snr_chart(noise, paper={0.005: 0.9, 0.05: 0.1, 0.2: 0.05})
    plot = chart[:-60]  # above the x labels and the legend
    blue_cols = np.flatnonzero(colour_mask(plot, BLUE).any(axis=0))
    green = colour_mask(plot, PAPER_GREEN)
    green_rows, green_cols = np.nonzero(green)
    # The share labels are written left of and above the paper's points, so its rightmost
    # pixels are the 0.5 % marker's and its lowest the 5 % marker's.
    assert abs(green_cols.max() - blue_cols.max()) <= 1
    lowest = green_cols[green_rows >= green_rows.max() - 1]
    assert abs(lowest.mean() - (blue_cols.min() + 3)) <= 1.5
    # The 0.5 % point is near the top (0.9), the 5 % one near the bottom (0.1).
    assert green_rows.max() - green_rows.min() > 0.6 * (plot.shape[0] - 40)
    # The same points as NoisePoints (their evaluation and both_rules figures) draw the same.
    objects = [
        SimpleNamespace(
            fraction=p["fraction"],
            snr_db=float("inf") if p["snr_db"] is None else p["snr_db"],
            mode=p["mode"],
            evaluation=SimpleNamespace(accuracy=p["accuracy"]),
            identified=None,
        )
        for p in noise
    ]
    again = pictures.snr_chart(objects, paper={0.005: 0.9, 0.05: 0.1, 0.2: 0.05})
    np.testing.assert_array_equal(again, chart)


def test_snr_chart_draws_identification_dashed_beside_the_any_spike_rule() -> None:
    shares = [(0.005, 10.0), (0.01, 7.0), (0.2, -6.0)]
    plain = [noise_point(f, s, m, 0.6, None) for f, s in shares for m in ("pent", "static")]
    both = [
        noise_point(f, s, m, 0.6, 0.3 if m == "pent" else 0.8)
        for f, s in shares
        for m in ("pent", "static")
    ]
    without, with_id = pictures.snr_chart(plain), pictures.snr_chart(both)
    assert is_bgr(with_id) and with_id.shape == without.shape == (460, 760, 3)
    for colour, level in ((BLUE, 0.3), (ORANGE, 0.8)):
        new = colour_mask(with_id[:-60], colour) & ~colour_mask(without[:-60], colour)
        rows = np.nonzero(new)[0]
        # a second line of the mode's colour, at identification's accuracy ...
        plot_top, plot_height = 36, with_id.shape[0] - 36 - 42 - 22
        expected = plot_top + (1 - level) * (plot_height - 1)
        assert rows.size and abs(np.median(rows) - expected) < 4
        # ... dashed: along its row, the colour has gaps where the solid line has none
        row = int(np.median(rows))
        cols = np.flatnonzero(colour_mask(with_id[row - 1 : row + 2], colour).any(axis=0))
        assert len(np.split(cols, np.flatnonzero(np.diff(cols) > 2) + 1)) >= 5
    # The default paper is Table 3 by share: at 0.5 % and 1 % here (its 85 and 83 %), both
    # drawn in green near 0.84, right of 7 dB's point; 20 % is not among its shares.
    green_rows, green_cols = np.nonzero(colour_mask(without[:-60], PAPER_GREEN))
    assert green_rows.size and abs(np.median(green_rows) - (36 + 0.16 * 339)) < 8
    ours = np.flatnonzero(colour_mask(without[:-60], ORANGE).any(axis=0))  # over PENT's
    seven = ours.min() + (ours.max() - ours.min()) * 13 / 16  # 7 dB in -6..10
    assert green_cols.min() > seven - 40  # the label "1 %" left of it, no point at -6 dB
