"""The real-signal rules on the smoke config: results, the table, and reruns that follow the config.

One build of the ``real_signals`` target in a fresh folder (the real captures,
the synthetic segments and what they need); the tests then read its results and
dry-run config changes against it.
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest
import yaml
from conftest import REPO, run_targets

from scintrack.config import load_config
from scintrack.io import hash_object, open_dataset
from scintrack.pipeline import params, paths
from scintrack.products import products

pytestmark = pytest.mark.pipeline
SMOKE = load_config([REPO / "config" / "config.yaml", REPO / "config" / "smoke.yaml"])
TABLE = "tables/real_signals/table_acquisition_tracking_real.csv"
#: the product rules of the real recordings (figures and the table)
PRODUCT_RULES = {name for name, p in products().items() if p.paper == "real_signals"}


def _jobs(text: str) -> dict[str, int]:
    return {m.group(1): int(m.group(2)) for m in re.finditer(r"^(\w+)\s+(\d+)$", text, re.M) if m.group(1) != "total"}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    workdir = tmp_path_factory.mktemp("real_signals")
    proc = run_targets(workdir, "real_signals", "-q")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return workdir


def test_results_hold_the_search_and_record_their_params(built):
    recordings = paths.signal_recordings(SMOKE)
    assert len(recordings) == 5 and {"synthetic_clean", "synthetic_jammed"} < set(recordings)
    for name in recordings:
        acq = open_dataset(built / paths.real_acquisition_path(name))
        assert acq.attrs["config_sha256"] == hash_object(params.real_acquisition(SMOKE, name))
        assert acq["prn"].values.tolist() == SMOKE["real_signals"]["acquisition"]["prns"]
        per_bin = acq["bin_statistic"].values
        # the per-bin statistic is the search itself: its best bin is the PRN's peak, Doppler and value
        np.testing.assert_allclose(per_bin.max(axis=1), acq["statistic"].values, rtol=1e-12)
        np.testing.assert_array_equal(acq["doppler"].values[per_bin.argmax(axis=1)], acq["doppler_hz"].values)
        assert np.array_equal(acq["detected"].values.astype(bool),
                              (acq["statistic"].values > float(acq["threshold"])) & (acq["cross_correlation_of"].values == 0))
    for name in SMOKE["real_signals"]["tracked"]:
        track = open_dataset(built / paths.real_tracking_path(name))
        acq = open_dataset(built / paths.real_acquisition_path(name))
        assert track.attrs["config_sha256"] == hash_object(params.real_tracking(SMOKE, name))
        assert track["prn"].values.tolist() == acq["prn"].values[acq["detected"].values.astype(bool)].tolist()
        # every counted transition is a sign change of the in-phase prompt, on one phase modulo 20 ms
        for i in range(track.sizes["prn"]):
            edges = np.flatnonzero(track["bit_edge"].values[i])
            prompt = track["prompt_i"].values[i]
            assert edges.size == int(track["n_bit_edges"].values[i])
            assert np.all(np.sign(prompt[edges]) != np.sign(prompt[edges - 1]))
            assert len(set(edges % 20)) <= 1


def test_the_table_lists_the_satellites_of_every_acquisition(built):
    table = pd.read_csv(built / TABLE, keep_default_na=False)
    tracked = set(SMOKE["real_signals"]["tracked"])
    for name in paths.signal_recordings(SMOKE):
        acq = open_dataset(built / paths.real_acquisition_path(name))
        rows = table[table["recording"] == name].set_index("PRN")
        detected = acq["prn"].values[acq["detected"].values.astype(bool)].tolist()
        assert set(detected) <= set(rows.index), name
        assert sorted(rows.index[rows["acquisition"] == "detected"]) == sorted(detected), name
        crossed = acq["prn"].values[acq["cross_correlation_of"].values > 0]
        assert all(rows.loc[p, "acquisition"].startswith("cross-correlation of PRN") for p in crossed)
        kind = "real" if name in paths.real_recordings(SMOKE) else "synthetic SKYDEL-like"
        assert set(rows["data"]) == {kind}
        with_tracking = set(rows.index[rows["lock fraction"] != ""])
        assert with_tracking == (set(detected) if name in tracked else set()), name
        for prn in detected:
            assert float(rows.loc[prn, "peak Lambda"]) == pytest.approx(float(acq["statistic"].sel(prn=prn)), abs=0.051)
    jammed = table[table["recording"] == "synthetic_jammed"]
    assert len(jammed) > 0 and set(jammed["acquisition"]) == {"not detected"}  # the row stays, with nothing acquired
    assert "synthetic_jammed acquires nothing" in (built / TABLE.replace(".csv", ".md")).read_text()


def _overlay(tmp_path, name: str, section: dict):
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump({"real_signals": section}))
    return path


def test_a_real_signals_value_reruns_exactly_the_real_signal_jobs(built, tmp_path):
    assert _jobs(run_targets(built, "real_signals", "-n").stdout) == {}  # up to date
    p_fa = run_targets(built, "real_signals", "-n", overlays=[_overlay(tmp_path, "pfa", {"acquisition": {"p_fa": 1e-4}})])
    assert p_fa.returncode == 0, p_fa.stderr[-2000:]
    assert _jobs(p_fa.stdout) == {"real_acquisition": 5, "real_tracking": 2, "real_signals": 1, **dict.fromkeys(PRODUCT_RULES, 1)}
    loop = run_targets(built, "real_signals", "gps_iq_recording", "-n",
                       overlays=[_overlay(tmp_path, "loop", {"tracking": {"pll_bandwidth_hz": 12.0}})])
    assert loop.returncode == 0, loop.stderr[-2000:]
    assert _jobs(loop.stdout) == {"real_tracking": 2, "real_fig_tracking_pocketsdr_iq": 1, "real_table_signals": 1, "real_signals": 1}


def test_a_recording_the_registry_lacks_is_one_error_line(built, tmp_path):
    proc = run_targets(built, "real_signals", "-n", overlays=[_overlay(tmp_path, "bad", {"recordings": {"real_nope": {}}})])
    assert proc.returncode != 0
    lines = [line for line in (proc.stdout + proc.stderr).splitlines() if line.startswith("error:")]
    assert len(lines) == 1 and "real_signals.recordings.real_nope" in lines[0] and "bad.yaml" in lines[0], lines
    assert "Traceback" not in proc.stderr


def test_figures_are_named_real_and_pass_the_layout_check(built):
    import json

    figures = {name: p for name, p in products("figure").items() if p.paper == "real_signals"}
    assert len(figures) == 4  # three acquisition figures and the tracking figure
    for name, product in figures.items():
        record = json.loads((built / product.outputs(SMOKE)["json"]).read_text())
        assert product.outputs(SMOKE)["png"].endswith("_real.png")
        assert record["data"] == "real" and record["verdict"]["status"] == "no paper figure" and record["verdict"]["text"], name
        assert record["layout_problems"] == [], (name, record["layout_problems"])
