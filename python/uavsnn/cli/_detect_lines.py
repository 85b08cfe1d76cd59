"""How ``uavsnn detect`` writes what it found: a window's decision or a conv3 spike, as a line of
text or of JSON (docs/streaming.md, "What ``uavsnn detect`` prints"). One stream's run and
several streams' on Ray write alike."""

from __future__ import annotations

from typing import Any

import numpy as np

from uavsnn import _jsonout


def spike_dict(d: np.void) -> dict[str, Any]:
    """One conv3 spike as ``--per-spike --json`` prints it."""
    x0, y0, x1, y1 = int(d["x0"]), int(d["y0"]), int(d["x1"]), int(d["y1"])
    return {
        "t": int(d["t"]),
        "window": int(d["window"]),
        "map": int(d["map"]),
        "row": int(d["row"]),
        "col": int(d["col"]),
        "box": [x0, y0, x1, y1],
        "centre": [(x0 + x1) / 2, (y0 + y1) / 2],
        "field_centre": [round(float(d["x"]), 2), round(float(d["y"]), 2)],
    }


def spike_line(d: np.void, as_json: bool) -> str:
    """One conv3 spike (``--per-spike``). ``centre`` is the middle of the spike's causal box;
    ``field`` the middle of the neuron's receptive field, which covers most of the sensor and
    so usually lies outside the box (docs/streaming.md)."""
    if as_json:
        return _jsonout.dumps(spike_dict(d))
    x0, y0, x1, y1 = int(d["x0"]), int(d["y0"]), int(d["x1"]), int(d["y1"])
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    return (
        f"t={int(d['t'])} window={int(d['window'])} map={int(d['map'])} "
        f"box={x0},{y0},{x1},{y1} centre={cx:.1f},{cy:.1f} "
        f"field={float(d['x']):.1f},{float(d['y']):.1f}"
    )


def absent(value: object) -> str:
    return "-" if value is None else str(value)


def rotor_text(o: Any) -> str:
    """The rotor signature when detected (docs/identification.md), ``-`` otherwise; its
    figures as the JSON line has them, shown to fewer places."""
    r = o.to_dict()["rotor"]  # the JSON line's
    if r is None:
        return "-"
    return f"{r['frequency_hz']:.1f}Hz/{r['strength']:.3f}/{r['pixels']}px"


def track_text(o: Any) -> str:
    """``7`` for a confirmed track, ``7?`` for a tentative one, ``-`` for none."""
    if o.track_id is None:
        return "-"
    return f"{o.track_id}{'' if o.track_confirmed else '?'}"


def window_line(w: Any, as_json: bool, classes: tuple[str, ...] = ()) -> str:
    """One window's decision (the default output; docs/streaming.md, "What ``uavsnn detect``
    prints"); ``classes``: the names of the model's class probabilities. The JSON line is
    :meth:`WindowReport.to_dict <uavsnn.grouping.WindowReport.to_dict>`'s dict."""
    if as_json:
        return _jsonout.dumps(w.to_dict(classes))
    line = (
        f"window={w.window}{f' run={w.run}' if w.run else ''} t={w.t0}..{w.t1} "
        f"{'DETECTED' if w.detected else 'clear'} "
        f"spikes={w.spikes} objects={len(w.objects)}"
    )
    for o in w.objects:
        x0, y0, x1, y1 = o.box
        cx, cy = o.centre
        line += (
            f" | box={x0},{y0},{x1},{y1} centre={cx:.1f},{cy:.1f} spikes={o.spikes} "
            f"uav_score={absent(o.uav_score)} class={absent(o.class_guess)} "
            f"track={track_text(o)} track_class={absent(o.track_class)} rotor={rotor_text(o)}"
        )
    return line
