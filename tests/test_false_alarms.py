"""False alarms over long UAV-free recording, streamed (``uavsnn.false_alarms``): the counting
rules on handmade windows, the scenes, and a tiny run end to end."""

from __future__ import annotations

import numpy as np
import pytest

from uavsnn import Network
from uavsnn.detector import WindowObject, WindowReport
from uavsnn.errors import ParameterError
from uavsnn.false_alarms import (
    alarm_rules,
    count_alarms,
    false_alarm_figures,
    false_alarm_table,
    stream_batch,
    summarise,
    uav_free_scenes,
)


def _obj(score, track, confirmed, track_score):
    return WindowObject(
        (0, 0, 4, 4), 1, uav_score=score, track_id=track, track_confirmed=confirmed,
        track_score=track_score,
    )  # fmt: skip


def test_windows_and_tracks_alarm_per_rule() -> None:
    none = np.zeros(0)
    reports = [
        # Detected: one object scoring 0.9 on a tentative track, one scoring 0.3.
        WindowReport(0, 0, 50, True, none, (_obj(0.9, 1, False, 0.9), _obj(0.3, 2, True, 0.3))),
        # Not detected: nothing alarms, whatever its objects.
        WindowReport(1, 25, 75, False, none, (_obj(0.99, 1, True, 0.95),)),
        # Detected: track 1 now confirmed at a mean of 0.7; an object without a score.
        WindowReport(2, 50, 100, True, none, (_obj(0.5, 1, True, 0.7), _obj(None, 3, True, None))),
    ]
    rules = {"any_spike": None, "strict": 0.8, "loose": 0.4}
    got = count_alarms(reports, rules)
    assert got["alarming"] == {"any_spike": 2, "strict": 1, "loose": 2}
    # any-spike: every confirmed track of a detected window (2, 1, 3); strict: none reaches
    # 0.8 while confirmed; loose: track 1 (0.7).
    assert got["tracks"] == {"any_spike": 3, "strict": 0, "loose": 1}


def test_the_scenes_are_uav_free_and_their_own() -> None:
    drawn = uav_free_scenes(0, 200)
    assert drawn == uav_free_scenes(0, 200) and drawn != uav_free_scenes(1, 200)
    assert {k for k, _ in drawn} == {"object", "empty"}
    assert 0.6 < sum(k == "object" for k, _ in drawn) / 200 < 0.8
    assert len({s for _, s in drawn}) == 200


def test_a_tiny_run_end_to_end() -> None:
    """Three recordings of 1 s through an untrained network: the figures are the rows'
    summary, per rule of the model (the any-spike rule alone without identification), and
    the same run gives the same figures."""
    net = Network(seed=0)
    assert alarm_rules(net) == {"any_spike": None}
    figures = false_alarm_figures(net, minutes=0.05, seed=3)
    assert figures["recordings"] == 3 and figures["minutes"] == pytest.approx(0.05)
    rows = stream_batch(net, uav_free_scenes(3, 3))
    assert figures == summarise(rows, alarm_rules(net)) | {"seed": 3}
    rule = figures["rules"]["any_spike"]
    assert rule["false_tracks"] == sum(r["tracks"]["any_spike"] for r in rows)
    assert rule["false_tracks_per_minute_upper95"] >= rule["false_tracks_per_minute"]
    assert figures["windows"] == sum(r["windows"] for r in rows) > 0
    assert "| any-spike |" in false_alarm_table(figures)
    assert false_alarm_figures(net, minutes=0.05, seed=3) == figures


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"minutes": 0}, "minutes must be in"),
        ({"minutes": 601}, "minutes must be in"),
        ({"minutes": 1, "seed": -1}, "seed must be"),
    ],
)
def test_bad_arguments_are_parameter_errors(kwargs, message) -> None:
    with pytest.raises(ParameterError, match=message):
        false_alarm_figures(Network(seed=0), **kwargs)
