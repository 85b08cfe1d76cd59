"""``uavsnn detect``: run a trained model over a live event stream and print detections.

SOURCE is a recording file (any format :func:`uavsnn.io.read` reads; as fast as possible, or at
the recording's own pace with ``--realtime``), ``-`` for standard input (``--stdin-format
packed``: canonical 13-byte records; ``csv``: ``t,x,y,p`` lines), or ``udp://HOST:PORT``
receiving faery's or aestream's UDP packets (``--udp-format``; see :mod:`uavsnn.sources` for the
exact layouts). Standard output gets one line per window, as soon as the window closes: the
decision, the count of conv3 spikes and their causal boxes merged into objects
(:func:`uavsnn.grouping.merge_boxes`), each with its track id (:mod:`uavsnn.tracks`) and its rotor
signature when one is detected (:mod:`uavsnn.signature`), and the UAV score and class guess of
the model's identification stage (:mod:`uavsnn.identify`; ``-``, JSON ``null``, for a model
without one, or an object beyond the rotor's limit); ``--per-spike`` prints
every conv3 spike instead, as it is decided; ``--json`` makes JSON lines of either. A rate
summary goes to standard error every ``--summary-every`` seconds and at the
end. Malformed packets are counted as drops (``dropped=``), the events of chunks the detector
rejects (an event outside the sensor, time going backwards) in ``rejected_events=``, and
skipped. Ctrl-C ends the stream: the windows still open are
reported, then the command exits 130 (``interrupted``), as every command does; SIGTERM and SIGHUP
do the same and exit 143 and 129 (:class:`uavsnn.cli.Terminated`). When the reader of standard
output goes away (``| head -1``) the command stops quietly, without its summary, and exits 1.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any, TextIO

from uavsnn import _jsonout
from uavsnn.cli._detect_lines import spike_dict, spike_line, window_line
from uavsnn.distributed import add_ray_option
from uavsnn.errors import ParameterError
from uavsnn.provenance import DEFAULT_OVERLAP, DEFAULT_WINDOW_US
from uavsnn.track_eval import Confirm

__all__ = ["register"]

_DESCRIPTION = """\
Run a trained model over a live event stream and print detections as they happen.

SOURCE is one of:
  FILE              a recording (AEDAT4, RAW EVT2/EVT3, DAT, ES, CSV, .npz, .npy), replayed as
                    fast as possible, or at its own pace with --realtime; --downsample fits a
                    larger sensor to the model's input
  -                 standard input: packed 13-byte records (t u64, x u16, y u16, p u8, little
                    endian: the bytes of uavsnn.EVENT_DTYPE), or t,x,y,p CSV lines with
                    --stdin-format csv
  udp://HOST:PORT   UDP packets in faery's t64_x16_y16_on8 (default) or t32_x16_y15_on1
                    format, or aestream's spif words (--udp-format spif)
'-' and UDP carry no sensor size: --sensor-size gives it (default: the model's input);
with --downsample, a larger camera's events are fitted to the model chunk by chunk.

MODEL (--model) is a trained model file: 'uavsnn train DATASET -o MODEL' writes one, and
'uavsnn demo --out DIR' writes DIR/model.npz (trained on its small built-in set).

Standard output gets one line per window when it closes: its decision (DETECTED when at least
detection.min_detections conv3 neurons fire, else clear), the number of conv3 spikes, and
their causal boxes merged into objects (boxes that overlap or touch are replaced by their
bounding box until none do), each with its centre and spike count, its track (an id linking
it across windows; '7?' while the track is tentative, '7' once confirmed) and its rotor
signature when one is detected (frequency/strength/agreeing pixels, else '-'); uav_score and
class come from the model's identification stage, '-' (null in JSON) for a model without one
(a note on standard error says so). --per-spike prints every
conv3 spike instead, as it is decided. Several sources (and --ray) run a detector per stream,
each in a Ray actor, and print the same lines led by the stream's name. --json makes JSON
lines of either. A rate summary goes
to standard error. Malformed packets, and chunks the detector rejects (events outside the
sensor, time going backwards), are counted as drops and skipped.
"""


#: The defaults of ``--stdin-format`` and ``--udp-format`` (``None`` unless given, so that
#: either is refused only when given for a source it does not apply to).
_STDIN_FORMAT = "packed"
_UDP_FORMAT = "t64_x16_y16_on8"


def register(subparsers: Any) -> None:
    """Add the ``detect`` sub-command."""
    p = subparsers.add_parser(
        "detect",
        help="detect UAVs in a recording, standard input or a UDP event stream",
        description=_DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("source", metavar="SOURCE", help="a recording file, '-', or udp://HOST:PORT")
    p.add_argument(
        "more_sources",
        nargs="*",
        default=[],  # optional: a missing SOURCE is the one argument "required"
        metavar="MORE_SOURCES",
        help="more files or udp://HOST:PORT streams, each with its own detector (needs --ray)",
    )
    p.add_argument(
        "--model",
        "-m",
        required=True,
        metavar="MODEL",
        help="trained model file (.npz): written by 'uavsnn train DATASET -o MODEL', or "
        "DIR/model.npz by 'uavsnn demo --out DIR'",
    )
    p.add_argument("--json", action="store_true", help="print JSON lines instead of text")
    p.add_argument(
        "--per-spike",
        action="store_true",
        help="print every conv3 spike as it is decided instead of one line per window",
    )
    p.add_argument(
        "--realtime", action="store_true", help="replay a file at its own pace (files only)"
    )
    p.add_argument(
        "--window-ms",
        type=float,
        help="window length in ms (default: the window the model was trained on, as uavsnn "
        f"info shows it; {DEFAULT_WINDOW_US / 1000:g} for a model that does not record it)",
    )
    p.add_argument(
        "--overlap",
        type=float,
        help="window overlap in [0, 1) (default: the model's training overlap; "
        f"{DEFAULT_OVERLAP:g} for a model that does not record it)",
    )
    p.add_argument(
        "--start-us",
        type=int,
        metavar="US",
        help="start of window 0 in µs of event time (default: the first event's time); 0 "
        "windows a recording as uavsnn evaluate's streams do",
    )
    p.add_argument(
        "--downsample",
        action="store_true",
        help="crop and scale the events to the model's input size: a file's sensor, or "
        "--sensor-size's for '-' and UDP (chunk by chunk)",
    )
    p.add_argument(
        "--sensor-size",
        metavar="WxH",
        help="sensor size: for '-' and UDP (default: the model's input size), and for files "
        "whose header has none (CSV; RAW/DAT without geometry: default from the header's "
        "camera generation, see 'uavsnn info')",
    )
    p.add_argument(
        "--stdin-format",
        choices=("packed", "csv"),
        default=None,
        help=f"'-': layout of standard input (default {_STDIN_FORMAT}, 13-byte records)",
    )
    p.add_argument(
        "--udp-format",
        choices=("t64_x16_y16_on8", "t32_x16_y15_on1", "spif"),
        default=None,
        help="UDP: packet format, faery's two formats or aestream's spif words (default "
        f"{_UDP_FORMAT})",
    )
    p.add_argument(
        "--max-packets", type=int, help="UDP: stop after this many packets (for scripts, tests)"
    )
    p.add_argument(
        "--idle-timeout",
        type=float,
        help="UDP: stop after this many seconds without a packet",
    )
    p.add_argument(
        "--idle-flush",
        type=float,
        metavar="S",
        help="'-' and UDP (each stream, with several): after S seconds without an event, take "
        "the stream's time to move on "
        "with the wall clock, less S, and report the windows that closes (the last windows "
        "of a quiet stream otherwise wait for its next event); an event stamped before that "
        "time arriving later is dropped. Off by default",
    )
    p.add_argument(
        "--summary-every",
        type=float,
        default=1.0,
        metavar="S",
        help="seconds between rate summaries on stderr (0: only at the end)",
    )
    p.add_argument(
        "--confirm",
        metavar="HITS/WINDOWS",
        help="the track confirmation rule: a track is confirmed (its id printed without '?') "
        "once it has objects in HITS of its last WINDOWS windows (default 3/5)",
    )
    p.add_argument(
        "--false-alarm",
        type=float,
        metavar="SHARE",
        help="identification's operating point: the threshold at which this share of the "
        "tuning recordings' UAV-free windows alarmed (0.01 or 0.05, as the model was tuned; "
        "default: the threshold tuned for balanced accuracy)",
    )
    p.add_argument(
        "--false-tracks",
        type=float,
        metavar="RATE",
        help="identification's operating point for tracks: the threshold at which this many "
        "confirmed tracks per minute of streamed UAV-free recording alarmed (0.1 or 1, as the "
        "model was tuned with `uavsnn train --track-minutes`), with the confirmation rule they "
        "were set with",
    )
    add_ray_option(
        p,
        "one detector per stream, each in a Ray actor (its lines led by the stream's name)",
    )
    p.set_defaults(handler=run)


def _sensor_size(text: str | None) -> tuple[int, int] | None:
    if text is None:
        return None
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError as exc:
        raise ParameterError(f"--sensor-size must look like 240x180, got {text!r}") from exc
    if width < 1 or height < 1:
        raise ParameterError(f"--sensor-size must be at least 1x1 pixels, got {text!r}")
    return width, height


class _Summary:
    """The live rate line on stderr."""

    def __init__(self, every: float, err: TextIO) -> None:
        self.every = every
        self.err = err
        self.start = time.monotonic()
        self.last = self.start

    def maybe(self, driver: Any) -> None:
        now = time.monotonic()
        if self.every > 0 and now - self.last >= self.every:
            self.last = now
            self.write(driver, final=False)

    def write(self, driver: Any, *, final: bool) -> None:
        wall = max(time.monotonic() - self.start, 1e-9)
        s = driver.source.stats
        events = driver.events_seen
        print(
            f"uavsnn detect: {'done' if final else 'live'} {wall:.1f}s "
            f"events={events} ({events / wall:,.0f} ev/s, "
            f"engine {driver.detector.rate:,.0f} ev/s) "
            f"windows={driver.windows_opened} "
            f"detections={driver.detections_emitted} packets={s.packets} "
            f"dropped={s.dropped} rejected_events={driver.rejected}"
            + ("" if s.lost is None else f" lost={s.lost}")
            + (f" restarts={s.restarts}" if s.restarts else ""),
            file=self.err,
            flush=True,
        )


#: The longest window ``--window-ms`` accepts: 2^62 µs, the engine's limit on times.
MAX_WINDOW_MS = float(1 << 62) / 1000


def _window_us(args: argparse.Namespace) -> int | None:
    """``--window-ms`` in µs, or ``None`` (the model's)."""
    return None if args.window_ms is None else round(args.window_ms * 1000)


def _check_args(args: argparse.Namespace) -> None:
    """Refuse flag values that make no sense before opening anything."""
    from uavsnn._validate import MAX_TIME_US
    from uavsnn.features import MAX_MEASURED_WINDOW_US
    from uavsnn.sources import check_seconds, is_live

    longest = MAX_MEASURED_WINDOW_US / 1000
    if args.window_ms is None:
        pass  # the model's
    elif not (math.isfinite(args.window_ms) and 0.001 <= args.window_ms <= MAX_WINDOW_MS):
        raise ParameterError(
            f"--window-ms must be a number of ms from 0.001 (1 µs) to {longest:g}, "
            f"got {args.window_ms}"
        )
    elif round(args.window_ms * 1000) > MAX_MEASURED_WINDOW_US:
        # The detector refuses it, advising its Python argument rotor=False, which the command
        # line has not: its objects' rotor and event rate are always measured.
        raise ParameterError(
            f"--window-ms {args.window_ms:g} is longer than {longest:g} "
            "ms, the longest window whose objects' rotor and event rate are measured: give a "
            "shorter --window-ms"
        )
    if args.overlap is not None and not (math.isfinite(args.overlap) and 0.0 <= args.overlap < 1.0):
        raise ParameterError(f"--overlap must be in [0, 1), got {args.overlap}")
    if args.start_us is not None and not 0 <= args.start_us <= MAX_TIME_US:
        raise ParameterError(
            f"--start-us must be a time in µs from 0 to {MAX_TIME_US}, got {args.start_us}"
        )
    if not (math.isfinite(args.summary_every) and args.summary_every >= 0):
        raise ParameterError(
            f"--summary-every must be a number of seconds >= 0 (0: only at the end), "
            f"got {args.summary_every}"
        )
    sources = (args.source, *args.more_sources)
    # An option of one kind of source applies to the sources of that kind (several sources
    # may mix them); refused when none is.
    live = all(is_live(s) for s in sources)
    if args.realtime and live:
        raise ParameterError(
            "--realtime replays a file at its own pace; standard input and UDP already "
            "arrive at theirs"
        )
    if not any(s.startswith("udp://") for s in sources):
        udp_only = (
            ("--max-packets", args.max_packets, "standard input and files end by themselves"),
            ("--idle-timeout", args.idle_timeout, "standard input and files end by themselves"),
            ("--udp-format", args.udp_format, "files and standard input have their own layouts"),
        )
        for flag, value, why in udp_only:
            if value is not None:
                raise ParameterError(f"{flag} applies to UDP sources (udp://HOST:PORT); {why}")
    if args.stdin_format is not None and "-" not in sources:
        raise ParameterError(
            "--stdin-format applies to standard input ('-'); files and UDP have their own layouts"
        )
    if args.idle_flush is not None and not any(is_live(s) for s in sources):
        raise ParameterError(
            f"--idle-flush applies to live sources ('-' or udp://HOST:PORT): {sources[0]} is "
            "a file, which ends by itself"
        )
    if args.max_packets is not None and args.max_packets < 1:
        raise ParameterError(f"--max-packets must be >= 1, got {args.max_packets}")
    for flag, seconds in (("--idle-flush", args.idle_flush), ("--idle-timeout", args.idle_timeout)):
        check_seconds(flag, seconds)
    if args.false_alarm is not None and args.false_tracks is not None:
        raise ParameterError("--false-alarm and --false-tracks each set the threshold: give one")
    for flag, value in (("--false-alarm", args.false_alarm), ("--false-tracks", args.false_tracks)):
        if value is not None and args.per_spike:
            raise ParameterError(
                f"{flag} sets identification's threshold for the window lines: not with "
                "--per-spike (it prints spikes, without UAV scores)"
            )
    if args.confirm is not None:
        if args.per_spike:
            raise ParameterError(
                "--confirm sets the tracks of the window lines: not with --per-spike (it prints "
                "spikes, without tracks)"
            )
        rule = Confirm.parse(args.confirm)
        if rule.fast is not None:
            raise ParameterError(
                f"--confirm {args.confirm}: detect takes HITS/WINDOWS; the score-aware rule "
                "(FAST+HITS/WINDOWS) is measured by `uavsnn evaluate --tracks` only"
            )


def _check_live_size(size: tuple[int, int], model_size: tuple[int, int]) -> None:
    """Refuse a ``--sensor-size`` for '-' or UDP other than the model's input, without
    ``--downsample``.

    Raises:
        ParameterError: the sizes differ, saying what the command line can do.
    """
    if tuple(size) == model_size:
        return
    w, h = size
    mw, mh = model_size
    raise ParameterError(
        f"the stream's sensor is {w}x{h} (--sensor-size), the model's input {mw}x{mh}: add "
        f"--downsample to crop and scale its events to the model (a larger sensor), send "
        f"events of a {mw}x{mh} sensor (--sensor-size {mw}x{mh}, the default), or use a model "
        f"of {w}x{h} (uavsnn train --set width={w} --set height={h}, on a dataset built with "
        f"--sensor {w}x{h})"
    )


def _check_distinct(sources: list[str]) -> None:
    """Refuse a source named twice, however spelled (``A.npz``, ``./A.npz``, a link to it).

    Raises:
        ParameterError: naming it.
    """
    from uavsnn.sources import is_live

    seen: dict[str, str] = {}
    for spec in sources:
        key = spec if is_live(spec) else str(Path(spec).resolve())
        if key in seen:
            same = "" if seen[key] == spec else f" (as {seen[key]} and {spec})"
            raise ParameterError(f"a source is named twice: {spec}{same}")
        seen[key] = spec


def _tracker(text: str | None, network: Any) -> Any:
    """The tracker of ``--confirm`` for ``network`` (its gate:
    :func:`uavsnn.tracks.tracker_for`; ``None``: the detector's default one)."""
    if text is None:
        return None
    from uavsnn.tracks import tracker_for

    rule = Confirm.parse(text)
    return tracker_for(network, confirm_hits=rule.hits, confirm_windows=rule.windows)


def _load(args: argparse.Namespace) -> Any:
    """The model of ``--model``, its identification at the operating point of
    ``--false-alarm`` or ``--false-tracks`` (``args.confirm`` then becomes the rule its track
    points were set with).

    Raises:
        ParameterError: either option for a model without identification, or ``--confirm``
            other than the track points' rule with ``--false-tracks``.
    """
    from uavsnn.network import Network

    network = Network.load(args.model)
    if args.false_alarm is not None or args.false_tracks is not None:
        flag = "--false-alarm" if args.false_alarm is not None else "--false-tracks"
        ident = network.identification
        if ident is None:
            raise ParameterError(
                f"{flag} sets identification's threshold; {args.model} has no "
                "identification (fit one with `uavsnn train`)"
            )
        point = (
            ident.at_false_alarm(args.false_alarm)
            if args.false_alarm is not None
            else ident.at_false_tracks(args.false_tracks)
        )
        network.identification = point
        if point.threshold <= 0.0 < ident.threshold:
            # The tuning set's UAV-free windows (tracks) stayed within the share with the
            # any-spike rule alone: the point scores nothing out, which the user should know.
            value = args.false_alarm if args.false_alarm is not None else args.false_tracks
            print(
                f"uavsnn detect: note: {flag} {value:g} is the threshold 0.0 on {args.model}: "
                "its tuning recordings stayed within that share with the any-spike rule "
                "alone, so every detection is called UAV, more than the model's default "
                f"threshold ({ident.threshold:.3g}) calls",
                file=sys.stderr,
                flush=True,
            )
        if args.false_tracks is not None:
            # The track points hold for the confirmation rule they were set with.
            stored = str(Confirm.of_pair(ident.track_alarm_confirm))
            if args.confirm is not None and str(Confirm.parse(args.confirm)) != stored:
                raise ParameterError(
                    f"--false-tracks {args.false_tracks:g}: {args.model}'s track points were "
                    f"set with --confirm {stored}, not {args.confirm}"
                )
            args.confirm = stored
    return network


def run(args: argparse.Namespace) -> int:
    """Run detection until the source ends, or Ctrl-C (SIGTERM, SIGHUP): what was found is
    still reported (the windows still open flushed), and the exit code is then 130 (143, 129),
    as for any interruption; 1, without the summary, when standard output's reader went away.
    Returns the exit code."""
    from uavsnn.cli import (
        exit_code,
        held_stops,
        interrupted_line,
        pipe_closed,
        quiet_stdout,
    )
    from uavsnn.detector import Detector
    from uavsnn.driver import StreamDriver
    from uavsnn.sources import (
        FileSource,
        IdleClock,
        UdpSource,
        check_fits,
        is_live,
        open_source,
    )

    _check_args(args)
    if args.more_sources or args.ray is not None:
        return _run_many(args)
    network = _load(args)
    model_size = (int(network.config["width"]), int(network.config["height"]))
    # '-' and UDP carry no sensor size: default to the model's; a file has its own.
    live = is_live(args.source)
    sensor_size = _sensor_size(args.sensor_size)
    if live:
        sensor_size = sensor_size or model_size
        if not args.downsample:
            _check_live_size(sensor_size, model_size)
    source = open_source(
        args.source,
        sensor_size=sensor_size,
        realtime=args.realtime,
        stdin_format=args.stdin_format or _STDIN_FORMAT,
        udp_format=args.udp_format or _UDP_FORMAT,
        max_packets=args.max_packets,
        idle_timeout=args.idle_timeout,
        downsample_to=model_size if args.downsample else None,
        heartbeat_s=IdleClock.heartbeat_for(args.idle_flush),
    )
    try:
        check_fits(source, model_size)
    except ParameterError:
        source.close()
        raise
    out, err = sys.stdout, sys.stderr
    with source:
        detector = Detector(
            network,
            window_us=_window_us(args),
            overlap=args.overlap,
            start_us=args.start_us,
            sensor_size=source.sensor_size,
            tracker=_tracker(args.confirm, network),
        )
        if isinstance(source, UdpSource):
            host, port = source.address
            print(f"uavsnn detect: listening on udp://{host}:{port}", file=err, flush=True)
            if source.buffer_note:
                print(f"uavsnn detect: warning: {source.buffer_note}", file=err, flush=True)
        if network.load_note:
            print(f"uavsnn detect: note: {network.load_note}", file=err, flush=True)
        otherwise = (
            None
            if network.trained_on is None
            else network.trained_on.windowed_otherwise(detector.window_us, detector.overlap)
        )
        if otherwise:
            print(
                f"uavsnn detect: note: {args.model} was {otherwise}; these are "
                f"{detector.window_us / 1000:g} ms, overlap {detector.overlap:g}: PENT's input "
                "count and the identification's features are measured over the window",
                file=err,
                flush=True,
            )
        if isinstance(source, FileSource) and source.recording.metadata.get("sensor_size_note"):
            # A size given against the camera its header names: taken, and said.
            note = source.recording.metadata["sensor_size_note"]
            print(f"uavsnn detect: note: {note}", file=err, flush=True)
        summary = _Summary(args.summary_every, err)
        ident = network.identification
        classes = tuple(ident.classes) if ident is not None else ()
        printed = 0  # the windows of the detector's stream (its run) printed

        def emit(found: Any) -> None:
            nonlocal printed
            if found is None or not len(found):
                return
            with held_stops():  # a stop waits for the lines: each whole, none dropped
                for item in found:
                    line = (
                        spike_line(item, args.json)
                        if args.per_spike
                        else window_line(item, args.json, classes)
                    )
                    print(line, file=out, flush=True)
                    printed += 1

        driver = StreamDriver(
            source, detector, idle_flush_s=args.idle_flush, windows=not args.per_spike
        )
        interrupted: KeyboardInterrupt | None = None
        size_said = False

        def size_note() -> None:
            # Standard input's first events mostly off the sensor: said once, not dropped quietly.
            nonlocal size_said
            note = getattr(source, "size_note", None)
            if note and not size_said:
                size_said = True
                print(f"uavsnn detect: warning: {note}", file=err, flush=True)

        try:
            refused = 0
            for step in driver:
                size_note()
                if step.kind == "restarted":
                    printed = 0
                    print(
                        f"uavsnn detect: the sensor restarted (its clock went back to "
                        f"t={step.t} µs): the old stream's "
                        "windows are reported, and detection starts again from there",
                        file=err,
                        flush=True,
                    )
                    continue
                if step.kind == "refused":
                    refused += 1
                    if refused <= 5:
                        print(f"uavsnn detect: dropped a chunk: {step.error}", file=err, flush=True)
                    continue
                emit(step.found)
                summary.maybe(driver)
        except KeyboardInterrupt as exc:
            # Ctrl-C (SIGTERM, SIGHUP): report what the stream found so far, then exit as
            # interrupted. Stopped inside the detector's own work, the stream is unknown:
            # nothing more to report.
            interrupted = exc
            if detector.interrupted:
                what = getattr(exc, "name", "Ctrl-C")
                # Every window the detector opened gets a line (a window in a silent gap is
                # neither opened nor printed): those opened and not printed are lost.
                lost = (
                    ""
                    if args.per_spike
                    else f" ({detector.windows_opened - printed} of "
                    f"{detector.windows_opened} opened)"
                )
                print(
                    f"uavsnn detect: {what} stopped the detector inside a chunk: the windows "
                    f"still open{lost} are not reported",
                    file=err,
                    flush=True,
                )
            else:
                emit(driver.flush())  # a closed pipe here ends as any (uavsnn.cli.main: exit 1)
        except OSError as exc:
            if not pipe_closed(exc, out):
                raise
            # The reader went away (``| head``): stop quietly, as command-line tools do (exit
            # 1, no summary: uavsnn.cli).
            quiet_stdout(out)
            return 1
        size_note()
        summary.write(driver, final=True)
    if interrupted is not None:
        # As the command line reports any interruption (uavsnn.cli.main): one line, 128 + the
        # signal's number.
        print(interrupted_line("uavsnn detect", interrupted), file=err, flush=True)
        return exit_code(interrupted)
    return 0


def _run_many(args: argparse.Namespace) -> int:
    """Several streams at once, one Detector per stream in a Ray actor (docs/distributed.md):
    each stream's window lines as they close (its conv3 spikes with ``--per-spike``), each led
    by its stream's name, as one stream's ``detect`` prints them; a stream that fails is
    reported and the others go on (exit 1 when any failed). Ctrl-C (SIGTERM, SIGHUP) stops
    every stream: each one's summary so far, then the interruption's line and exit code."""
    from uavsnn.cli import exit_code, held_stops, interrupted_line
    from uavsnn.distributed import StreamResult, detect_streams, runner_for
    from uavsnn.sources import is_live

    sources = [args.source, *args.more_sources]
    if "-" in sources:
        raise ParameterError("standard input ('-') cannot be one of several streams")
    _check_distinct(sources)
    if args.ray is None:
        raise ParameterError("several sources need --ray (one detector per stream, on Ray)")
    network = _load(args)
    if any(is_live(s) for s in sources) and not args.downsample:
        model_size = (int(network.config["width"]), int(network.config["height"]))
        _check_live_size(_sensor_size(args.sensor_size) or model_size, model_size)
    runner = runner_for(args.ray)
    out, err = sys.stdout, sys.stderr
    if network.load_note:
        print(f"uavsnn detect: note: {network.load_note}", file=err, flush=True)
    ident = network.identification
    classes = tuple(ident.classes) if ident is not None else ()
    latest: dict[str, StreamResult] = {}
    start = last = time.monotonic()

    def summary(r: StreamResult, state: str) -> None:
        wall = max(time.monotonic() - start, 1e-9)
        detected = "" if args.per_spike else f" detected={r.windows_detected}"
        print(
            f"uavsnn detect: {r.name}: {state} {wall:.1f}s events={r.events_seen} "
            f"({r.events_seen / wall:,.0f} ev/s) windows={r.windows}{detected} "
            f"detections={r.spikes} packets={r.packets} dropped={r.dropped} "
            f"rejected_events={r.rejected_events}"
            + (f" restarts={r.restarts}" if r.restarts else ""),
            file=err, flush=True,
        )  # fmt: skip

    def ready(addresses: dict[str, tuple[str, int] | None], _actors: Any) -> None:
        for name, address in addresses.items():
            if address is not None:
                print(f"uavsnn detect: {name}: listening on udp://{address[0]}:{address[1]}",
                      file=err, flush=True)  # fmt: skip

    def found(name: str, items: Any) -> None:
        with held_stops():  # a stop waits for the lines: each whole, none dropped
            for item in items:
                if args.json:
                    d = spike_dict(item) if args.per_spike else item.to_dict(classes)
                    print(_jsonout.dumps({"stream": name, **d}), file=out)
                else:
                    line = spike_line(item, False) if args.per_spike else window_line(item, False)
                    print(f"[{name}] {line}", file=out)
            out.flush()

    def update(r: StreamResult) -> None:
        nonlocal last
        before = latest.get(r.name)
        if r.restarts > (before.restarts if before is not None else 0):
            print(
                f"uavsnn detect: {r.name}: the sensor restarted (its clock went back): the old "
                "stream's windows are reported, and detection starts again from there",
                file=err, flush=True,
            )  # fmt: skip
        latest[r.name] = replace(r)
        now = time.monotonic()
        if args.summary_every > 0 and now - last >= args.summary_every:
            last = now
            for name in sorted(latest):
                if latest[name].ok:
                    summary(latest[name], "live")

    try:
        results = detect_streams(
            runner, sources, network, window_us=_window_us(args),
            overlap=args.overlap, start_us=args.start_us, on_ready=ready,
            on_detections=found, on_update=update, windows=not args.per_spike,
            tracker=_tracker(args.confirm, network), keep=False,
            sensor_size=_sensor_size(args.sensor_size), realtime=args.realtime,
            udp_format=args.udp_format, max_packets=args.max_packets,
            idle_timeout=args.idle_timeout, downsample=args.downsample,
            idle_flush_s=args.idle_flush,
        )  # fmt: skip
    except KeyboardInterrupt as exc:
        # Every stream stopped (detect_streams stops the actors): what each found so far.
        for name in sources:
            if name in latest:
                r = latest[name]
                summary(r, _state(r) if r.ended else "interrupted")
        print(interrupted_line("uavsnn detect", exc), file=err, flush=True)
        return exit_code(exc)
    for r in results.values():
        summary(r, _state(r))
    return 0 if all(r.ok for r in results.values()) else 1


def _state(r: Any) -> str:
    """How a stream of several ended: ``done``, or ``failed (why)``."""
    return "done" if r.ok else f"failed ({r.error})"
