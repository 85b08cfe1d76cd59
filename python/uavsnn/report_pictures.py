"""The pictures of a report (SPEC §6): learned features and how they evolved (the paper's
Figs. 6–9), detections over event frames (Fig. 10), a noisy window with PENT on and off (Fig.
11), accuracy against SNR (Table 3), the confusion matrix, and what each shows (its caption).

:func:`figures` writes the PNGs and returns their paths; :func:`picture_links` gives the
Markdown that shows them with their captions. :mod:`uavsnn.report` writes the tables beside
them and re-exports these names.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from uavsnn import pictures
from uavsnn._files import output_dir
from uavsnn.dataset import LabelledWindows
from uavsnn.evaluation import Evaluation
from uavsnn.experiments import NoisePoint
from uavsnn.network import Network
from uavsnn.training import TrainingResult
from uavsnn.windows import add_noise

__all__ = [
    "CAPTIONS",
    "TRAINED_CONV1_CAPTION",
    "caption",
    "conv1_trained",
    "figures",
    "picture_links",
]


def figures(
    out_dir: str | Path,
    network: Network,
    test: LabelledWindows,
    evaluation: Evaluation,
    *,
    training: TrainingResult | None = None,
    noise: Sequence[NoisePoint] = (),
    static: Network | None = None,
    seed: int = 0,
    prefix: str = "",
) -> dict[str, Path]:
    """Write the report's pictures into ``out_dir``; returns ``{name: path}``.

    ``evaluation`` must have been made with ``keep_inference=True`` for the detection
    pictures. ``static`` (the same weights under static thresholds) adds the PENT on/off
    picture.

    Raises:
        ParameterError: ``out_dir`` is a file, cannot be created, or is not writable.
    """
    out = output_dir(Path(out_dir), "out_dir")
    written: dict[str, Path] = {}

    def put(name: str, image: np.ndarray) -> None:
        written[name] = pictures.write_png(out / f"{prefix}{name}.png", image)

    for layer, image in pictures.feature_images(network).items():
        put(f"features-{layer}", image)
    if training is not None:
        for layer, result in training.layers.items():
            if len(result.snapshots) < 2:
                continue
            shots = []
            for seen, weights in result.snapshots:
                copy = network.copy()
                copy.identification = None  # the pictures read the weights alone
                copy.set_weights(layer, weights)
                shots.append((f"{seen} windows", pictures.reconstruct_features(copy, layer)))
            put(
                f"evolution-{layer}",
                pictures.feature_evolution(shots, title=f"{layer} features during STDP"),
            )
        put("convergence", _convergence_chart(training))
    put(
        "confusion",
        pictures.confusion_image(
            evaluation.confusion, title=f"any-spike rule, {evaluation.windows} test windows"
        ),
    )
    if evaluation.inference is not None:
        put("detections", _detections_sheet(test, evaluation))
    if static is not None:
        put("pent", _pent_sheet(network, static, test, seed))
    if noise:
        put("snr", pictures.snr_chart(noise))
    return written


def _convergence_chart(training: TrainingResult) -> np.ndarray:
    longest = max(len(r.report.convergence) for r in training.layers.values())
    x = np.arange(1, longest + 1, dtype=float)
    series = {}
    for layer, result in training.layers.items():
        c = np.full(longest, np.nan)
        c[: len(result.report.convergence)] = result.report.convergence
        series[layer] = c.tolist()
    return pictures.line_chart(
        x.tolist(),
        series,
        title="convergence C = mean(w(1-w))",
        xlabel="training windows",
        ylabel="C",
        markers=False,
    )


def _pick(mask: np.ndarray, count: int) -> list[int]:
    return [int(i) for i in np.flatnonzero(mask)[:count]]


def _detections_sheet(test: LabelledWindows, evaluation: Evaluation) -> np.ndarray:
    inference = evaluation.inference
    assert inference is not None
    predicted, actual = evaluation.predicted, test.label
    chosen = (
        [("true positive", i) for i in _pick(predicted & actual, 3)]
        + [("false positive", i) for i in _pick(predicted & ~actual, 1)]
        + [("missed", i) for i in _pick(~predicted & actual, 1)]
    )
    if not chosen:
        chosen = [("window", 0)]
    frames = test.windows.frames([i for _, i in chosen])
    found = inference.detections
    panels = []
    for (what, i), frame in zip(chosen, frames, strict=True):
        box = test.box[i]
        panels.append(
            pictures.detections_image(
                frame,
                found[found["window"] == i],
                truth_box=None if np.isnan(box).any() else tuple(float(v) for v in box),
                title=f"{what}: {test.cls[i]} (window {i})",
            )
        )
    rows = [pictures.hstack(panels[k : k + 3]) for k in range(0, len(panels), 3)]
    return pictures.vstack(rows)


def _pent_sheet(network: Network, static: Network, test: LabelledWindows, seed: int) -> np.ndarray:
    uav = np.flatnonzero(test.label)
    index = int(uav[0]) if uav.size else 0
    noisy, snr = add_noise(test.windows.select([index]), 0.05, seed=seed)
    t, x, y = noisy.spikes(0)
    t0 = int(noisy.t0[0])
    frame = noisy.frames([0])[0]
    return pictures.pent_comparison(
        frame,
        network.run_window(t, x, y, t0),
        static.run_window(t, x, y, t0),
        title=f"a UAV window with noise on 5 % of pixels (SNR {float(snr[0]):.1f} dB)",
    )


_FEATURES = (
    "Each tile is one map's learned feature in input pixels, scaled to its own range: white is "
    "a strong weight, black a weak one. {layer}'s features are composed down through the layers "
    "below (docs/model.md §2), so they are as wide as its receptive field. A feature with clear "
    "white strokes (edges, a blob) has been learned; a uniform grey tile is a map that STDP has "
    "barely moved from its initial weights."
)

#: What each picture of :func:`figures` shows and how to read it, by name.
CAPTIONS = {
    "features-conv1": "conv1's Gabor kernels (fixed, not learned): one tile "
    "per orientation, white is positive weight. They respond to edges of that orientation.",
    "features-conv2": _FEATURES.format(layer="conv2"),
    "features-conv3": _FEATURES.format(layer="conv3"),
    "evolution-conv2": "conv2's features (as in features-conv2) at snapshots during STDP, left "
    "to right by windows seen: features that sharpen from the uniform start show what training "
    "changed.",
    "evolution-conv3": "conv3's features at snapshots during STDP, as evolution-conv2.",
    "convergence": "The convergence measure C = mean(w(1-w)) of each trained layer's weights "
    "against training windows. C is 0 when every weight sits at 0 or 1 (converged) and at most "
    "0.25 (all weights at 0.5). Weights start at 0.8 +- 0.08 (C = 0.154) and STDP drives most "
    "of them to 0, so C first rises while they pass through 0.5 and only then falls: a curve "
    "still rising at the end means the layer stopped mid-way, not that it diverged "
    "(benches/python/convergence_trace.py measures it: in the demo, after 2000 windows conv3's "
    "mean weight is 0.53 and C 0.22; after 20000, 98 % of its weights are below 0.1 and C is "
    "0.000).",
    "confusion": "The any-spike rule's confusion matrix on the test windows: rows are the truth "
    "(UAV or not), columns the decision; the diagonal is right.",
    "detections": "Test windows as time-embedded frames (the paper's Fig. 10): each pixel's "
    "first event coloured from cyan (early in the window) to magenta (late), silent pixels dark. "
    "Yellow boxes are the causal boxes of conv3's spikes, labelled with their maps; the dashed "
    "green box is the labelled object. Three true positives, one false positive and one miss, "
    "where the test set has them.",
    "pent": "One UAV test window with noise added on 5 % of the pixels (the paper's Fig. 11): "
    "the noisy input, then conv1's spikes with PENT (thresholds raised with the number of "
    "active pixels) and with static thresholds, each with every layer's spike count and conv1's "
    "threshold range under it. PENT should keep conv1 from firing on the noise everywhere.",
    "snr": "Test accuracy against the median SNR of the noisy test windows at each noise share "
    "(higher is cleaner): one colour per network (PENT, static thresholds), the any-spike rule "
    "solid and detection + identification dashed. The paper's Table 3 (green) is lined up by "
    "noise share, as SPEC §5 compares it: each of its six figures is drawn at our median SNR of "
    "the same share (0.5 % ... 5 %, labelled), not at its own dB labels, which cannot all come "
    "from one signal. 0.5 is chance on the balanced test set.",
    "roc": "Detection + identification on the dvs test windows, one curve per network: the "
    "share of UAV windows detected against the share of UAV-free windows alarming, as the "
    "threshold on the UAV score moves. A window the any-spike rule misses never alarms, so each "
    "curve ends at that rule's own point. The bars at 1 % and 5 % false alarms: each point's "
    "95 % interval when the test recordings are drawn again.",
}


#: The caption of features-conv1 for a network whose conv1 was trained (``uavsnn train
#: --layers conv1,...``): its kernels are no longer the Gabor bank of :data:`CAPTIONS`.
TRAINED_CONV1_CAPTION = (
    "conv1's kernels, trained by STDP (no longer the Gabor kernels its config gives): one tile "
    "per map, scaled to its own range: white is a strong weight, black a weak one. A kernel "
    "with clear white strokes responds to edges of that shape; a uniform grey tile is a map "
    "that STDP has barely moved."
)


def conv1_trained(network: Network) -> bool:
    """Whether ``network``'s conv1 kernels differ from the Gabor kernels its config gives (a
    model file holds the weights, not whether a layer was trained: conv1 trained by STDP has
    moved off them)."""
    gabor = Network(network.config).weights("conv1")
    return not np.array_equal(network.weights("conv1"), gabor)


def caption(name: str, network: Network | None = None) -> str:
    """The caption of picture ``name`` of :func:`figures` (empty for an unknown name); with the
    ``network`` pictured, features-conv1's says whether its kernels are the fixed Gabor ones
    (:func:`conv1_trained`; without it, they are taken to be)."""
    if name == "features-conv1" and network is not None and conv1_trained(network):
        return TRAINED_CONV1_CAPTION
    return CAPTIONS.get(name, "")


def picture_links(
    written: dict[str, Path], markdown_dir: str | Path, *, network: Network | None = None
) -> list[str]:
    """Markdown image lines for :func:`figures`' PNGs, relative to the folder of the Markdown
    file that shows them, each followed by its caption (what it shows, how to read it; with
    the ``network`` pictured, :func:`caption`'s for it)."""
    base = Path(markdown_dir)
    lines = []
    for name, path in written.items():
        lines.append(f"![{name}]({path.relative_to(base).as_posix()})\n")
        text = caption(name, network)
        if text:
            lines.append(f"\n*{name}: {text}*\n\n")
    return lines
