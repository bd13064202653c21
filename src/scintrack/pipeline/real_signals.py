"""What the schema cannot say about the ``real_signals`` section, and the input files of its rules.

Read while Snakemake builds the DAG (``workflow/rules/real_signals.smk``):
the recordings named in the config must exist in the dataset registry, their
files and sidecars must be on disk, and the acquisition blocks and the
tracking spans must fit in each recording's length (from its sidecar, or the
config for a synthetic segment), so a wrong value stops the run before any
job with one line naming the key.  Config mistakes raise
:class:`~scintrack.errors.ConfigError` (the workflow names the config layer
that set the key), missing files :class:`~scintrack.errors.InputError`.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

from ..errors import ConfigError, InputError, one_line
from ..project import project_file
from . import params, paths


def recording_length_ms(config: Mapping[str, Any], name: str) -> float:
    """Length of a recording [ms] from its sidecar (real) or the config (synthetic segment), without reading samples."""
    if name in paths.SYNTHETIC_SEGMENTS:
        return 1e3 * float(config["gps_jamming"]["iq"]["length_s"])
    side = project_file(paths.real_recordings(config)[name]["sidecar"])
    try:
        meta = json.loads(side.read_text(encoding="utf-8"))
        return 1e3 * int(meta["n_samples"]) / float(meta["sample_rate_hz"])
    except (OSError, ValueError, KeyError, TypeError, ZeroDivisionError) as exc:
        raise InputError(f"{side}: cannot read n_samples and sample_rate_hz ({one_line(exc)}); "
                         "restore the sidecar (git checkout data/real) or fix it (docs/real-signals.md)") from None


def recording_files(config: Mapping[str, Any], name: str) -> dict[str, str]:
    """The data file and sidecar of a recording: the repository's copy of a real one, gps_iq_recording's output for a segment."""
    files = paths.signal_recording_files(config, name)
    if name in paths.SYNTHETIC_SEGMENTS:
        return files
    return {k: str(project_file(v)) for k, v in files.items()}


def check(config: Mapping[str, Any], source: str) -> None:
    """Names that exist, files on disk, lengths that fit; ``source`` names the config file in the messages."""
    rs = config["real_signals"]
    registry = config["real_traces"]["registry"]
    real = paths.real_recordings(config)
    recordings = paths.signal_recordings(config)
    for name, entry in real.items():
        for key in ("path", "sidecar"):
            if not project_file(entry[key]).is_file():
                raise InputError(f"real recording {name}: {entry[key]} not found; restore it (git checkout data/real) "
                                 f"or remove its entry from {project_file(registry)}")
    for name in rs["recordings"]:
        if name not in real:
            raise ConfigError(f"invalid config value at 'real_signals.recordings.{name}': not a recording of the registry {registry} "
                              f"(known: {', '.join(real) or 'none'}); fix it in {source}")
    for name in recordings:
        acq = params.real_acquisition(config, name)["acquisition"]
        need, length = int(acq["n_coherent_ms"]) * int(acq["n_blocks"]), recording_length_ms(config, name)
        if need > length + 1e-9:
            key = "real_signals.synthetic" if name in paths.SYNTHETIC_SEGMENTS else f"real_signals.recordings.{name}"
            raise ConfigError(f"invalid config value at '{key}': n_coherent_ms x n_blocks = {acq['n_coherent_ms']} x {acq['n_blocks']} ms "
                              f"does not fit in the {length:g}-ms recording {name}; set a shorter block or fewer blocks in {source}")
    tr = rs["tracking"]
    if tr["pull_in_ms"] < tr["mm_m2m4_window"]:
        raise ConfigError(f"invalid config value at 'real_signals.tracking.pull_in_ms': {tr['pull_in_ms']} ms must cover mm_m2m4_window "
                          f"({tr['mm_m2m4_window']} epochs of 1 ms): the MM filter's noise prior comes from the pull-in; fix it in {source}")
    for name in rs["tracked"]:
        if name not in recordings:
            raise ConfigError(f"invalid config value at 'real_signals.tracked': {name!r} is not a recording "
                              f"(known: {', '.join(recordings)}); fix it in {source}")
        need, length = max(tr["pull_in_ms"] + 20, tr["fine_search_ms"]) + 2, recording_length_ms(config, name)
        if length < need:
            raise ConfigError(f"invalid config value at 'real_signals.tracked': {name} lasts {length:g} ms, less than the {need} ms "
                              "tracking needs (real_signals.tracking.pull_in_ms + one 20-ms data bit, and fine_search_ms); "
                              f"remove it or shorten those settings in {source}")
