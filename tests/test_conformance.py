"""The conformance check of scintrack.testing: every built-in tracker type passes it, and it catches broken trackers
(wrong shape, NaN output, an undeclared tracking key, a trial that reads another, a kernel that departs from its
reference) with one plain AssertionError each.  The toy trackers are registered for one test only."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from conftest import REPO

from scintrack.config import load_config
from scintrack.testing import check_tracker
from scintrack.trackers import registry
from scintrack.trackers.base import Tracker, TrackOutput


def _builtin_specs() -> dict[str, dict]:
    """One configured spec of every built-in type (the first in config order that needs no trace), without ``type``."""
    config = load_config([REPO / "config" / "config.yaml"])
    out: dict[str, dict] = {}
    for spec in config["trackers"].values():
        if spec["type"] not in out and spec.get("design") != "trace":
            out[spec["type"]] = {k: v for k, v in spec.items() if k != "type"}
    return out


SPECS = _builtin_specs()


def test_every_builtin_type_has_a_configured_spec_to_check():
    assert sorted(SPECS) == sorted(t for t in registry.known_types() if registry.from_package(t))


@pytest.mark.parametrize("kind", sorted(SPECS))
def test_every_builtin_tracker_type_conforms(kind):
    report = check_tracker(kind, SPECS[kind])
    assert report["reference_checked"] and report["inputs"] == {"CSM": (4, 300), "GPS": (4, 300)}
    assert set(report["tracking_keys_read"]) <= set(registry.get(kind).tracking_keys)


@dataclass
class Toy(Tracker):
    """Holds the phase of each prompt (a 'tracker' with no loop); correct, so each broken variant departs in one way."""

    ts: float

    SCHEMA = {}  # no annotation: a class attribute, not a dataclass field
    TRACKING_KEYS = ("fd0_hz",)
    PROVIDES = frozenset({"discriminator"})

    @classmethod
    def from_spec(cls, spec, context):
        context.tracking["fd0_hz"]
        return cls(ts=context.ts)

    @staticmethod
    def label(name, spec):
        return "Toy"

    def run(self, y, init):
        return TrackOutput(theta_d=np.angle(y), extras={"discriminator": np.zeros(y.shape)})

    def reference(self, y, init):
        return self.run(y, init)



class WrongShape(Toy):
    def run(self, y, init):
        out = super().run(y, init)
        return TrackOutput(theta_d=out.theta_d[:, 1:], extras=out.extras)


class NanOutput(Toy):
    def run(self, y, init):
        theta = np.angle(y)
        theta[:, 5] = np.nan
        return TrackOutput(theta_d=theta, extras={"discriminator": np.zeros(y.shape)})


class UndeclaredKey(Toy):
    @classmethod
    def from_spec(cls, spec, context):
        context.tracking["fd0_hz"]
        context.tracking["pll_bandwidth_hz"]  # read, not in TRACKING_KEYS
        return cls(ts=context.ts)


class ReadsOtherTrials(Toy):
    def run(self, y, init):
        return TrackOutput(theta_d=np.angle(y) - np.angle(y).mean(axis=0), extras={"discriminator": np.zeros(y.shape)})


class DepartsFromReference(Toy):
    def reference(self, y, init):
        out = self.run(y, init)
        return TrackOutput(theta_d=out.theta_d + 1e-3, extras=out.extras)


@pytest.fixture
def register_toys():
    registry.known_types()
    saved = dict(registry._TYPES)
    for name, cls in {"toy_ok": Toy, "toy_shape": WrongShape, "toy_nan": NanOutput, "toy_key": UndeclaredKey,
                      "toy_batch": ReadsOtherTrials, "toy_ref": DepartsFromReference}.items():
        registry.register(name)(cls)
    yield
    registry._TYPES.clear()
    registry._TYPES.update(saved)


def test_a_correct_toy_passes(register_toys):
    assert check_tracker("toy_ok")["tracking_keys_read"] == ["fd0_hz"]


@pytest.mark.parametrize(("kind", "message"), [
    ("toy_shape", r"^tracker type 'toy_shape' on the CSM input: run gave theta_d of shape \(4, 299\) for prompts of shape \(4, 300\)"),
    ("toy_nan", r"^tracker type 'toy_nan' on the CSM input: run gave 4 non-finite value\(s\) of theta_d, the first at \(trial, epoch\) \(0, 5\)"),
    ("toy_key", r"^tracker type 'toy_key' on the CSM input: from_spec read the tracking key\(s\) pll_bandwidth_hz that TRACKING_KEYS does not declare"),
    ("toy_batch", r"^tracker type 'toy_batch' on the CSM input: trial 0's theta_d depends on the batch it ran in"),
    ("toy_ref", r"^tracker type 'toy_ref' on the CSM input: run and reference disagree on theta_d"),
])
def test_a_broken_tracker_fails_with_one_plain_message(register_toys, kind, message):
    with pytest.raises(AssertionError, match=message) as exc:
        check_tracker(kind)
    assert "\n" not in str(exc.value)


def test_an_unknown_type_or_a_spec_its_schema_refuses_fails_plainly(register_toys):
    with pytest.raises(AssertionError, match=r"^tracker type 'nowhere': unknown tracker type 'nowhere' .*is its package installed"):
        check_tracker("nowhere")
    with pytest.raises(AssertionError, match=r"^tracker type 'pll': its spec is refused by its SCHEMA: .*bandwidth_hz"):
        check_tracker("pll", {"bandwidth_hz": -1})
