"""What a model was trained on: the windows it learned from and the recordings whose windows
trained its layers, fitted or tuned its identification.

``uavsnn train`` records it in the model file (:attr:`uavsnn.network.Network.trained_on`;
the entry ``trained_on``, a versioned JSON text stored as ``uint8``, as the config is). Its
uses:

- :class:`~uavsnn.detector.Detector` and ``uavsnn detect`` window a stream as the model was
  trained (its ``window_us`` and ``overlap``) unless told otherwise: the identification's
  features, event counts and rates among them, are measured over the window;
- ``uavsnn evaluate`` says when the split it scores holds a recording the model was trained
  on (:meth:`TrainedOn.shared_with`): its figures on those recordings are no test.

Recordings are told apart as ``uavsnn train --tune`` tells them apart
(:func:`recording_key`): a rendered scene by its domain and seed, a real clip by its video
file. ``uavsnn train``, ``demo`` and ``reproduce`` write the entry; a model file without it
(written by the library alone, or by an earlier uavsnn) has ``trained_on = None``: the
defaults of 50 ms and 0.5 apply, and nothing is checked.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from uavsnn.errors import ModelFileError

__all__ = [
    "ARRAY",
    "DEFAULT_OVERLAP",
    "DEFAULT_WINDOW_US",
    "VERSION",
    "TrainedOn",
    "model_windows",
    "recording_key",
    "recordings_of",
    "split_ids",
]

#: The model file's entry.
ARRAY = "trained_on"
#: The window and overlap of a model that does not record its training windows, and of a
#: dataset whose manifest does not say (:class:`~uavsnn.detector.Detector`'s defaults then).
DEFAULT_WINDOW_US = 50_000
DEFAULT_OVERLAP = 0.5
#: The entry's version: a file of a later one is refused.
VERSION = 1


def model_windows(trained: TrainedOn | None) -> tuple[int, float]:
    """The window and overlap a model runs at unless told otherwise: those it was ``trained``
    on, else :data:`DEFAULT_WINDOW_US` and :data:`DEFAULT_OVERLAP`."""
    if trained is None:
        return DEFAULT_WINDOW_US, DEFAULT_OVERLAP
    return trained.window_us, trained.overlap


def recording_key(entry: Any) -> tuple[str, ...] | None:
    """What a manifest's recording entry is, whichever dataset lists it: a rendered scene by
    its domain and seed (a dataset's recording ``i`` of a split is seeded by the dataset's seed,
    domain, split and ``i`` alone), a real clip by its video file; ``None`` when unknown."""
    if not isinstance(entry, dict):
        return None
    seed = entry.get("seed")
    if isinstance(seed, int) and not isinstance(seed, bool):
        return ("scene", str(entry.get("domain")), str(seed))
    video = entry.get("video")
    if isinstance(video, str) and video:
        return ("clip", video)
    return None


def split_ids(manifest: Mapping[str, Any]) -> dict[int, str]:
    """Recording id -> the split whose windows it gave, from a manifest's splits."""
    out: dict[int, str] = {}
    splits = manifest.get("splits")
    for split, entry in (splits if isinstance(splits, dict) else {}).items():
        ids = entry.get("recordings") if isinstance(entry, dict) else None
        for rid in ids if isinstance(ids, list) else []:
            if isinstance(rid, int):
                out.setdefault(rid, str(split))
    return out


def recordings_of(
    manifest: Mapping[str, Any], used: Mapping[int, str]
) -> dict[tuple[str, ...], tuple[str, str]]:
    """Key (:func:`recording_key`) -> (name, split) of the recordings ``used`` (id -> split)
    of a dataset with ``manifest``."""
    entries = manifest.get("recordings")
    if not isinstance(entries, list):
        return {}
    out: dict[tuple[str, ...], tuple[str, str]] = {}
    for entry in entries:
        key = recording_key(entry)
        rid = entry.get("id") if isinstance(entry, dict) else None
        if key is None or not isinstance(rid, int) or rid not in used:
            continue
        name = entry["video"] if key[0] == "clip" else str(entry.get("name", rid))
        out[key] = (name, used[rid])
    return out


@dataclass(frozen=True)
class TrainedOn:
    """What a model was trained on (module docs).

    Attributes:
        window_us, overlap: the training windows' length and overlap.
        recordings: each recording whose windows trained, fitted or tuned the model, as
            ``(key, name)``: its :func:`recording_key` and its name for messages.
    """

    window_us: int
    overlap: float
    recordings: tuple[tuple[tuple[str, ...], str], ...] = ()

    @classmethod
    def of(cls, manifest: Mapping[str, Any], recording_ids: Any) -> TrainedOn:
        """What a dataset with ``manifest`` gives a model trained on the windows of the
        recordings ``recording_ids`` (a split's ``recording`` column, its ids repeated)."""
        parameters = manifest.get("parameters")
        parameters = parameters if isinstance(parameters, dict) else {}
        ids = {int(r) for r in np.unique(np.asarray(recording_ids)).tolist()}
        found = recordings_of(manifest, dict.fromkeys(ids, ""))
        return cls(
            window_us=int(parameters.get("window_us", DEFAULT_WINDOW_US)),
            overlap=float(parameters.get("overlap", DEFAULT_OVERLAP)),
            recordings=tuple(sorted((key, name) for key, (name, _) in found.items())),
        )

    @classmethod
    def of_sets(cls, first: Any, *more: Any) -> TrainedOn:
        """What a model trained, fitted or tuned on the labelled windows ``first`` and ``more``
        (:class:`uavsnn.dataset.LabelledWindows`, each with its dataset's manifest) is trained
        on: every set's recordings, the window of ``first``."""
        out = cls.of(first.manifest or {}, first.recording)
        for data in more:
            out = cls.of(data.manifest or {}, data.recording).joined(out)
        return out

    def joined(self, other: TrainedOn) -> TrainedOn:
        """Both sets of recordings; the window of ``other`` (the later training: an
        identification fitted again measures its features on its own windows)."""
        both = dict(self.recordings) | dict(other.recordings)
        return TrainedOn(other.window_us, other.overlap, tuple(sorted(both.items())))

    def windowed_otherwise(self, window_us: float, overlap: float) -> str | None:
        """``"trained on windows of 50 ms, overlap 0.5"`` when windows of ``window_us`` and
        ``overlap`` are not the model's, for a note (``uavsnn evaluate`` on a dataset windowed
        otherwise, ``uavsnn detect`` told another window); ``None`` when they are."""
        if (window_us, overlap) == (self.window_us, self.overlap):
            return None
        return f"trained on windows of {self.window_us / 1000:g} ms, overlap {self.overlap:g}"

    def shared_with(self, manifest: Mapping[str, Any], split: str) -> list[str]:
        """The names of the recordings of a dataset's ``split`` (``manifest``: the dataset's)
        that this model was trained on, in order."""
        ids = {rid: s for rid, s in split_ids(manifest).items() if s == split}
        mine = dict(self.recordings)
        found = recordings_of(manifest, ids)
        return sorted(name for key, (name, _) in found.items() if key in mine)

    def to_array(self) -> np.ndarray:
        """The model file's entry: the JSON text as ``uint8``."""
        text = json.dumps(
            {
                "version": VERSION,
                "window_us": self.window_us,
                "overlap": self.overlap,
                "recordings": [[list(key), name] for key, name in self.recordings],
            },
            separators=(",", ":"),
        )
        return np.frombuffer(text.encode("utf-8"), dtype=np.uint8)

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray]) -> TrainedOn | None:
        """The entry of a model file's arrays, or ``None`` without one.

        Raises:
            ModelFileError: an entry that is not this version's JSON, or whose fields are
                missing or of the wrong kind.
        """
        if ARRAY not in arrays:
            return None
        array = np.asarray(arrays[ARRAY])
        try:
            if array.dtype != np.uint8 or array.ndim != 1:
                raise ValueError(f"a 1-D uint8 array is expected, not {array.dtype} {array.shape}")
            data = json.loads(array.tobytes().decode("utf-8"))
            if not isinstance(data, dict) or data.get("version") != VERSION:
                version = data.get("version") if isinstance(data, dict) else None
                raise ValueError(f"version {version!r}, this uavsnn reads {VERSION}")
            window_us, overlap = data["window_us"], data["overlap"]
            if isinstance(window_us, bool) or not isinstance(window_us, int) or window_us < 1:
                raise ValueError(f"window_us {window_us!r}")
            if isinstance(overlap, bool) or not isinstance(overlap, (int, float)):
                raise ValueError(f"overlap {overlap!r}")
            if not 0 <= overlap < 1:
                raise ValueError(f"overlap {overlap!r}")
            recordings = []
            for item in data["recordings"]:
                key, name = item
                if not (
                    isinstance(key, list)
                    and key
                    and all(isinstance(k, str) for k in key)
                    and isinstance(name, str)
                ):
                    raise ValueError(f"recording {item!r}")
                recordings.append((tuple(key), name))
        except (ValueError, KeyError, TypeError, UnicodeDecodeError) as exc:
            raise ModelFileError(f"its {ARRAY} entry is damaged: {exc}") from exc
        return cls(int(window_us), float(overlap), tuple(recordings))
