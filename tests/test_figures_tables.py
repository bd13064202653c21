"""Figure byte-stability and Table I summaries on constructed inputs."""

from __future__ import annotations

import numpy as np
import xarray as xr

from scintrack.checksums import read_checksums, write_checksums
from scintrack.products.figures import vila_valls_2018 as figs
from scintrack.products.figures.common import save_figure
from scintrack.products.tables.vila_valls_2018 import table01_long, table01_twin


def _diag():
    freqs = np.linspace(0, 50, 65)
    rng = np.random.default_rng(0)
    shape = (2, 2)
    return xr.Dataset(
        {
            "psd_empirical": (("case", "component", "freq"), rng.uniform(0.1, 1, shape + (65,))),
            "psd_ar": (("case", "component", "order", "freq"), rng.uniform(0.1, 1, shape + (4, 65))),
            "pacf": (("case", "component", "pacf_lag"), rng.uniform(-1, 1, shape + (7,))),
            "pacf_bound": (("case", "component", "pacf_lag"), np.full(shape + (7,), 0.05)),
            "s4": ("case", [0.9, 0.5]),
            "tau0": ("case", [0.1, 0.4]),
        },
        coords={"case": ["severe", "moderate"], "component": ["amplitude", "phase"], "order": [1, 2, 3, 4], "freq": freqs, "pacf_lag": np.arange(7)},
        attrs={"ts": 0.01},
    )


def test_figures_are_byte_stable(tmp_path):
    diag = _diag()
    first = save_figure(figs.fig01(diag), [tmp_path / "a.pdf", tmp_path / "a.png"])
    second = save_figure(figs.fig01(diag), [tmp_path / "b.pdf", tmp_path / "b.png"])
    for x, y in zip(first, second):
        assert x.read_bytes() == y.read_bytes()
    assert b"CreationDate" not in first[0].read_bytes()


def test_saving_draws_a_tight_layout_figure_once_per_file_with_matplotlibs_own_bytes(tmp_path, monkeypatch):
    """``save_figure`` drops the placeholder engine ``tight_layout()`` leaves, which made matplotlib draw the
    figure twice per file: one draw per file now, and the bytes matplotlib writes with the engine left in place."""
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure
    from matplotlib.layout_engine import PlaceHolderLayoutEngine

    from scintrack.products.figures.common import PDF_METADATA, PNG_METADATA, STYLE

    diag = _diag()
    kept = figs.fig01(diag)
    assert isinstance(kept.get_layout_engine(), PlaceHolderLayoutEngine)  # what tight_layout() leaves
    with plt.rc_context(STYLE):
        kept.savefig(tmp_path / "kept.pdf", format="pdf", metadata=PDF_METADATA)
        kept.savefig(tmp_path / "kept.png", format="png", metadata=PNG_METADATA)
    plt.close(kept)
    fig = figs.fig01(diag)  # drawn once while built (its legend is measured), then counted
    draws = []
    original = Figure.draw
    monkeypatch.setattr(Figure, "draw", lambda self, renderer: (draws.append(1), original(self, renderer))[1])
    save_figure(fig, [tmp_path / "saved.pdf", tmp_path / "saved.png"])
    assert len(draws) == 2
    for ext in ("pdf", "png"):
        assert (tmp_path / f"saved.{ext}").read_bytes() == (tmp_path / f"kept.{ext}").read_bytes(), ext


def test_every_figure_function_renders(tmp_path):
    diag = _diag()
    for fig in (figs.fig01(diag), figs.fig02(diag, 6), figs.fig03(diag), figs.fig04(diag, 6)):
        save_figure(fig, [tmp_path / "x.png"])
        assert (tmp_path / "x.png").stat().st_size > 10_000


def test_checksum_manifest_lists_files_relative_and_sorted(tmp_path):
    (tmp_path / "sub").mkdir()
    a, b = tmp_path / "sub" / "b.txt", tmp_path / "a.txt"
    a.write_text("A")
    b.write_text("b")
    manifest = write_checksums(tmp_path / "SHA256SUMS", [a, b])
    text = manifest.read_text()
    assert text.splitlines()[0].endswith("  a.txt") and text.splitlines()[1].endswith("  sub/b.txt")  # sorted by name
    sums = read_checksums(manifest)
    assert sums["sub/b.txt"] == "559aead08264d5795d3909718cdd05abd49572e84fe55590eef31a88a08fdffd"  # sha256("A")
    assert write_checksums(tmp_path / "SHA256SUMS", [b, a]).read_text() == text  # order of inputs does not matter


def _lut(orders):
    s4 = [0.2, 0.5, 0.9]
    data = np.zeros((3, 1, 2, 2, 3), dtype=np.int32)  # s4, tau0, trial, component, criterion
    for i, s in enumerate(s4):
        data[i] = orders[s]
    return xr.Dataset(
        {"trial_selected_order": (("s4", "tau0", "trial", "component", "criterion"), data)},
        coords={"s4": s4, "tau0": [0.1], "trial": [0, 1], "component": ["amplitude", "phase"], "criterion": ["pacf", "aic", "bic"]},
    )


def test_table01_modes_and_shares():
    one = np.array([[[3, 3, 3], [1, 1, 1]], [[3, 4, 4], [2, 2, 2]]])  # trial x component x criterion
    lut = _lut({0.2: one, 0.5: one, 0.9: one})
    long = table01_long(lut)
    row = long[(long.region == "severe") & (long.component == "amplitude") & (long.criterion == "aic")].iloc[0]
    assert row.modal_order == 3 and row.share_of_fits == 0.5 and row.max_order == 4  # tie -> lower order
    phase = long[(long.region == "severe") & (long.component == "phase") & (long.criterion == "pacf")].iloc[0]
    assert phase.modal_order == 1 and phase.matches_paper
    twin = table01_twin(long)
    assert list(twin.region) == ["severe", "moderate", "low"]
