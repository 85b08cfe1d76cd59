"""Where detections point: the engine's boxes (the input spikes that caused the conv3 spike,
docs/model.md §5) against the earlier definition (every input spike of time <= t inside the
conv3 neuron's receptive field), on the true positives of a labelled test set.

For each true positive, the first detection's box is compared with the labelled UAV box: IoU,
distance between centres, and box size. The earlier boxes are rebuilt here from the window's
input spikes and the receptive field of ``tests/reference/dense.py``::

    uavsnn demo --out /tmp/demo        # or any model and dataset
    python benches/python/compare_boxes.py /tmp/demo/model.npz /tmp/demo/data
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from uavsnn import Network, dataset
from uavsnn.evaluation import box_iou, centre_distance, first_detection_boxes

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_engine import DEFAULT_DENSE, load_dense


def field_boxes(network: Network, windows, inference, which: np.ndarray) -> np.ndarray:
    """The earlier boxes of the first detections of windows ``which``."""
    dense = load_dense(DEFAULT_DENSE)
    if dense is None:
        raise SystemExit(f"cannot import the dense reference {DEFAULT_DENSE}")
    found = inference.detections
    windows_with, first_row = np.unique(found["window"], return_index=True)
    row_of = dict(zip(windows_with.tolist(), first_row.tolist(), strict=True))
    out = np.full((len(which), 4), np.nan)
    for k, i in enumerate(which):
        d = found[row_of[int(i)]]
        row, col = int(d["row"]), int(d["col"])
        x0, y0, x1, y1 = dense.receptive_field(network.config, "conv3", row, col)
        a, b = int(windows.offsets[i]), int(windows.offsets[i + 1])
        t, x, y = windows.t[a:b], windows.x[a:b], windows.y[a:b]
        inside = (t <= d["t"]) & (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
        if inside.any():
            xs, ys = x[inside], y[inside]
            out[k] = [xs.min(), ys.min(), xs.max() + 1, ys.max() + 1]
    return out


def figures(boxes: np.ndarray, labelled: np.ndarray) -> dict[str, float]:
    iou = box_iou(boxes, labelled)
    off = centre_distance(boxes, labelled)
    return {
        "iou_median": float(np.median(iou)),
        "centre_error_px_median": float(np.median(off)),
        "centre_error_px_p90": float(np.percentile(off, 90)),
        "width_median": float(np.median(boxes[:, 2] - boxes[:, 0])),
        "height_median": float(np.median(boxes[:, 3] - boxes[:, 1])),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", type=Path)
    parser.add_argument("data", type=Path, help="dataset folder (its test split is used)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    network = Network.load(args.model)
    test = dataset.load(args.data, "test")
    inference = network.infer(test.windows)
    labelled = np.asarray(test.box, dtype=np.float64)
    tp = np.flatnonzero(inference.detected & test.label & np.isfinite(labelled).all(axis=1))
    if not len(tp):
        raise SystemExit("no true positive with a labelled box")
    rows = {
        "causes (engine)": figures(first_detection_boxes(inference, len(test))[tp], labelled[tp]),
        "receptive field (earlier)": figures(
            field_boxes(network, test.windows, inference, tp), labelled[tp]
        ),
        "labelled boxes": {
            "width_median": float(np.median(labelled[tp, 2] - labelled[tp, 0])),
            "height_median": float(np.median(labelled[tp, 3] - labelled[tp, 1])),
        },
    }
    if args.json:
        print(json.dumps({"true_positives": len(tp), **rows}, indent=2))
        return
    print(f"{len(tp)} true positives with a labelled box; first detection's box against it:")
    for name, f in rows.items():
        text = f"  {name:26s} size {f['width_median']:.0f}x{f['height_median']:.0f} px"
        if "iou_median" in f:
            text += (
                f", IoU {f['iou_median']:.2f}, centre {f['centre_error_px_median']:.1f} px off "
                f"(p90 {f['centre_error_px_p90']:.1f})"
            )
        print(text)


if __name__ == "__main__":
    main()
