"""Build the jammed GPS scenario dataset described in :mod:`scintrack.data.gps_jamming_spec`.

Kept apart from the light params/version module so that the workflow's DAG
parsing does not import the orbit, clock and message code; the dataset's
code version is the import closure of this module.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..io import sha256_file
from ..models import clock as clock_model
from ..seeding import stable_key
from ..signals.gps import ephemeris, geometry, jamming, message, orbit
from .gps_jamming_spec import CODE_PERIOD_S, F_L1, GENERATOR, GENERATOR_VERSION, LAMBDA_L1, NAME, C, gps_jamming_version

LIGHT_TIME_ITERATIONS = 3
CLOCK_MARGIN_S = 1.0  # the clock is simulated over the scenario plus this much on each side


def gps_seconds(utc: str, leap_seconds: int) -> tuple[int, float]:
    """(GPS week, seconds of week) of a UTC ISO time, GPS = UTC + leap seconds."""
    t = np.datetime64(utc, "ns") + np.timedelta64(int(leap_seconds), "s")
    week, sow = ephemeris.seconds_of_week(np.array([t]))
    return int(week[0]), float(sow[0])


def utc_text(week: int, sow: float, leap_seconds: int) -> str:
    t = ephemeris.GPS_EPOCH + np.timedelta64(int(round((week * ephemeris.SECONDS_PER_WEEK + sow - leap_seconds) * 1e3)), "ms")
    return str(t.astype("datetime64[s]"))


def _check_file(path: Path, params: Mapping[str, Any]) -> None:
    want = params.get("ephemerides_sha256")
    name = Path(params["ephemerides"]).name
    if not path.exists():
        raise ValueError(f"{params['ephemerides']}: ephemerides file not found; restore it (git checkout) or set gps_jamming.ephemerides")
    if not want:
        raise ValueError(f"{params['ephemerides']}: no sha256 in data/registry.yaml; add an entry ephemerides_{name.replace('.', '_')} with its sha256")
    got = sha256_file(path)
    if got != want:
        raise ValueError(f"{params['ephemerides']}: sha256 {got[:12]}... differs from the registry's {want[:12]}...; restore the file or update data/registry.yaml")


def choose_window(params: Mapping[str, Any], groups, header: ephemeris.NavHeader, rx: np.ndarray) -> geometry.WindowChoice:
    """The scenario window: the configured start, or the lowest worst-case GDOP window of the search span."""
    win = params["window"]
    duration = float(params["duration_s"])
    if params["start_utc"]:
        week, t_from = gps_seconds(params["start_utc"], header.leap_seconds)
        t_to, step = t_from + duration, duration
    else:
        week, t_from = gps_seconds(win["from_utc"], header.leap_seconds)
        _, t_to = gps_seconds(win["to_utc"], header.leap_seconds)
        step = float(win["step_s"])
        if abs(round(duration / step) * step - duration) > 1e-9:
            raise ValueError(f"gps_jamming.window.step_s ({step:g}) must divide duration_s ({duration:g})")
    return geometry.select_window(groups, rx, params["prns"], duration, float(win["min_elevation_deg"]), week, t_from, t_to, step)


def _receiver_clock(params: Mapping[str, Any], n: int, seed_seq: np.random.SeedSequence):
    """One realisation of the receiver clock offset (s) and drift (s/s) on a 1-ms true-time grid."""
    model = clock_model.preset(params["clock"])
    return clock_model.simulate(model, CODE_PERIOD_S, n, seed_seq, units="s")


def _receive_times(eph, rx, t_sv: np.ndarray, header, params) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """True GPS receive times of the code epochs sent at SV times ``t_sv``, and the geometry there."""
    t_tx = t_sv - orbit.satellite_state(eph, t_sv).clock_bias  # SV time -> GPS time of transmission
    t = t_tx + 0.075
    iono = header if params["iono"] else None
    for _ in range(LIGHT_TIME_ITERATIONS):
        truth = geometry.signal_truth(eph, rx, t, iono=iono, tropo=bool(params["tropo"]))
        t = t_tx + truth["transit_s"] + (truth["iono_m"] + truth["tropo_m"]) / C
    return t, truth


def _arrival(m: np.ndarray, m_ref: int, t0: float, truth: dict[str, np.ndarray], rx_clock: np.ndarray) -> np.ndarray:
    """Receiver-clock arrival of SV-time code epochs ``m`` (ms), in seconds from the scenario start ``t0``.

    ``t_sv - t0`` comes from integers; then GPS transmit time = t_sv - dt_sv, plus the
    vacuum transit and the atmospheric delays, plus the receiver clock offset.
    """
    rel_sv = (m - m_ref) * CODE_PERIOD_S + (m_ref * CODE_PERIOD_S - t0)
    return rel_sv - truth["sat_clock_s"] + truth["transit_s"] + (truth["iono_m"] + truth["tropo_m"]) / C + rx_clock


def build(params: Mapping[str, Any], path: str | Path) -> xr.Dataset:
    """The dataset for ``params`` (:func:`scintrack.data.gps_jamming_spec.gps_jamming_params`) from the ephemerides at ``path``."""
    path = Path(path)
    _check_file(path, params)
    ephs = ephemeris.load(path)
    header = ephemeris.read_header(path)
    groups = ephemeris.by_prn(ephs)
    rec = params["receiver"]
    rx = geometry.receiver_ecef(rec["lat_deg"], rec["lon_deg"], rec["height_m"])
    win = choose_window(params, groups, header, rx)
    week, t0, duration = win.week, win.t_start, float(params["duration_s"])
    n = int(round(duration / CODE_PERIOD_S))
    root = np.random.SeedSequence(int(params["seed"]), spawn_key=(stable_key(NAME),))
    clock_seq, phase_seq = root.spawn(2)
    n_clock = int(round((duration + 2 * CLOCK_MARGIN_S) / CODE_PERIOD_S)) + 1
    clock_t = t0 - CLOCK_MARGIN_S + CODE_PERIOD_S * np.arange(n_clock)
    clock_s, drift = _receiver_clock(params, n_clock, clock_seq)
    phi0 = np.random.Generator(np.random.PCG64(phase_seq)).uniform(0.0, 1.0, len(win.prns))

    jam = params["jammer"]
    kappa = jamming.spectral_separation(float(jam["bandwidth_hz"]), float(jam["offset_hz"]))
    cn0_clean = float(params["cn0_dbhz"])
    cn0_jammed = float(jamming.effective_cn0_dbhz(cn0_clean, float(jam["js_db"]), kappa))

    in_bit: list[int] = []
    nav_bit0: list[int] = []
    per_sv: dict[str, list[np.ndarray]] = {k: [] for k in ("receive_time", "pseudorange", "carrier_phase", "doppler", "cn0", "bit", "range", "rx_clock", "sat_clock", "iono", "tropo")}
    messages = []
    uploads = [message.Upload(int(u["prn"]), t0 + float(u["time_s"])) for u in params["uploads"]]
    lead = float(params["message_lead_s"])
    for k, prn in enumerate(win.prns):
        eph = win.data_sets[prn]
        # Code epochs are counted in whole milliseconds of SV time (integers), and every
        # quantity below is formed from small differences: seconds of week near 3e5 s
        # carry float64 steps of 6e-11 s, i.e. 1.7 cm of range and 0.09 cycle of phase.
        m_ref = int(round(t0 * 1000.0))
        m_first = m_ref - 100  # 100 ms before the start: earlier than any arrival
        for _ in range(3):
            t_probe, probe = _receive_times(eph, rx, np.array([m_first * CODE_PERIOD_S]), header, params)
            arrival = _arrival(m_first, m_ref, t0, probe, np.interp(t_probe, clock_t, clock_s))
            m_first += int(np.ceil(-arrival[0] / CODE_PERIOD_S - 1e-6))
        m = m_first + np.arange(n, dtype=np.int64)
        t, truth = _receive_times(eph, rx, m * CODE_PERIOD_S, header, params)
        rx_clock = np.interp(t, clock_t, clock_s)
        rx_drift = np.interp(t, clock_t, drift)
        receive_time = _arrival(m, m_ref, t0, truth, rx_clock)
        pseudorange = truth["range_m"] + truth["iono_m"] + truth["tropo_m"] + C * (rx_clock - truth["sat_clock_s"])
        carrier = -(pseudorange - 2.0 * truth["iono_m"]) / LAMBDA_L1 + phi0[k]
        atmos_rate = np.gradient(truth["tropo_m"] - truth["iono_m"], receive_time)
        doppler = -(truth["range_rate_m_s"] + C * (rx_drift - truth["sat_clock_drift"]) + atmos_rate) / LAMBDA_L1
        msg = message.build_message(ephs, header, prn, week, t0 - lead, t0 + duration + 1.0, uploads=[u for u in uploads if u.prn == prn])
        m_msg = int(round(msg.t0 * 1000.0))
        idx = (m - m_msg) // 20
        if idx[0] < 0 or idx[-1] >= len(msg.bits):
            raise AssertionError(f"PRN {prn}: message does not cover the scenario")  # build_message spans [t_start, t_end]
        messages.append(msg)
        in_bit.append(int((m[0] - m_msg) % 20))
        nav_bit0.append(int((m[0] - m_msg) // 20))
        per_sv["receive_time"].append(receive_time)
        per_sv["pseudorange"].append(pseudorange)
        per_sv["carrier_phase"].append(carrier)
        per_sv["doppler"].append(doppler)
        per_sv["cn0"].append(np.where(receive_time >= float(jam["onset_s"]), cn0_jammed, cn0_clean).astype(np.float32))
        per_sv["bit"].append((1 - 2 * msg.bits[idx]).astype(np.int8))
        per_sv["range"].append(truth["range_m"])
        per_sv["rx_clock"].append(rx_clock)
        per_sv["sat_clock"].append(truth["sat_clock_s"])
        per_sv["iono"].append(truth["iono_m"])
        per_sv["tropo"].append(truth["tropo_m"])

    ds = _assemble(params, win, header, rx, per_sv, messages, kappa, cn0_jammed, path)
    ds["first_epoch_in_bit"] = (("sv",), np.array(in_bit, dtype=np.int8), {"long_name": "code period of epoch 0 within its 20-ms data bit (0 = bit edge)"})
    ds["nav_bit_of_epoch0"] = (("sv",), np.array(nav_bit0, dtype=np.int32), {"long_name": "index in nav_bits of the data bit that epoch 0 carries"})
    return ds


def _geometry_1s(win: geometry.WindowChoice, rx: np.ndarray, header, params) -> dict[str, np.ndarray]:
    t = win.t_start + np.arange(0.0, win.duration_s + 0.5, 1.0)
    az, el, rng = [], [], []
    for prn in win.prns:
        truth = geometry.signal_truth(win.data_sets[prn], rx, t)
        az.append(truth["az_deg"])
        el.append(truth["el_deg"])
        rng.append(truth["range_m"])
    az, el = np.array(az), np.array(el)
    dops = geometry.dop(az.T, el.T)
    return {"time": t - win.t_start, "az": az, "el": el, "range": np.array(rng), **{k: np.asarray(v) for k, v in dops.items()}}


def _assemble(params, win, header, rx, per_sv, messages, kappa, cn0_jammed, path) -> xr.Dataset:
    sv_epoch = ("sv", "epoch")
    m0 = messages[0]
    nav_t = m0.t0 - win.t_start + 0.02 * np.arange(len(m0.bits))
    sub_t = np.asarray(m0.subframe_t0, dtype=float) - win.t_start
    geo = _geometry_1s(win, rx, header, params)

    def var(key, long_name, units, dtype=np.float64):
        return (sv_epoch, np.array(per_sv[key], dtype=dtype), {"long_name": long_name, "units": units})

    def per_subframe(attr, dtype):
        return (("sv", "subframe"), np.array([np.asarray(getattr(m, attr)) for m in messages], dtype=dtype))

    ds = xr.Dataset(
        {
            "receive_time": var("receive_time", "arrival of the code epoch on the receiver clock, from the scenario start", "s"),
            "pseudorange": var("pseudorange", "pseudorange c (receive clock - SV transmit time)", "m"),
            "carrier_phase": var("carrier_phase", "carrier phase -(pseudorange - 2 iono)/lambda_L1 + phi0", "cycles"),
            "doppler": var("doppler", "carrier Doppler d(carrier_phase)/dt", "Hz"),
            "cn0": var("cn0", "true C/N0 (effective C/N0 after the jammer onset)", "dB-Hz", np.float32),
            "bit": var("bit", "transmitted LNAV level during the code period (+1 = bit 0)", "1", np.int8),
            "range": var("range", "geometric range (light time, Earth rotation)", "m"),
            "rx_clock": var("rx_clock", "receiver clock offset", "s"),
            "sat_clock": var("sat_clock", "satellite clock correction (L1 C/A, relativistic and T_GD included)", "s"),
            "iono": var("iono", "ionospheric L1 group delay (Klobuchar)", "m", np.float32),
            "tropo": var("tropo", "tropospheric delay", "m", np.float32),
            "azimuth": (("sv", "time_1s"), geo["az"], {"long_name": "azimuth", "units": "deg"}),
            "elevation": (("sv", "time_1s"), geo["el"], {"long_name": "elevation", "units": "deg"}),
            "range_1s": (("sv", "time_1s"), geo["range"], {"long_name": "geometric range", "units": "m"}),
            **{k: (("time_1s",), geo[k], {"long_name": k.upper(), "units": "1"}) for k in ("gdop", "pdop", "hdop", "vdop", "edop", "ndop", "tdop")},
            "nav_bits": (("sv", "nav_bit"), np.array([m.bits for m in messages], dtype=np.int8), {"long_name": "transmitted LNAV bits (0/1, after parity inversion)"}),
            "nav_source": (("sv", "nav_bit"), np.array([m.source for m in messages], dtype=np.int8), {"long_name": "LNAV source bits (0/1, decoded content)"}),
            "subframe_start": (("subframe",), sub_t, {"long_name": "subframe start (SV time) from the scenario start", "units": "s"}),
            "subframe_id": (("subframe",), np.asarray(m0.subframe_id, dtype=np.int8)),
            "page": (("subframe",), np.asarray(m0.page, dtype=np.int8), {"long_name": "subframe 4/5 page (-1 in subframes 1-3)"}),
            "sv_id": per_subframe("sv_id", np.int16) + ({"long_name": "SV ID (page ID) of subframes 4/5 (-1 in subframes 1-3)"},),
            "iodc": per_subframe("iodc", np.int16) + ({"long_name": "IODC of the data set in force"},),
            "iode": per_subframe("iode", np.int16) + ({"long_name": "IODE copy carried by the subframe (SF1: IODC 8 LSBs; SF2, SF3: IODE; -1 in SF4/5)"},),
            "t_oe": per_subframe("t_oe", np.float64) + ({"long_name": "t_oe of the data set in force", "units": "s of GPS week"},),
            "dataset_kind": (("sv", "subframe"), np.array([[str(k) for k in m.dataset_kind] for m in messages], dtype=str)),
        },
        coords={
            "prn": ("sv", np.array(win.prns, dtype=np.int16)),
            "time_1s": ("time_1s", geo["time"], {"units": "s"}),
            "nav_bit_time": ("nav_bit", nav_t, {"long_name": "bit start (SV time) from the scenario start", "units": "s"}),
        },
    )
    rec = params["receiver"]
    jam = params["jammer"]
    ds.attrs.update(
        dataset_name=NAME,
        dataset_version=gps_jamming_version(params),
        generator=GENERATOR,
        generator_version=GENERATOR_VERSION,
        source="synthetic (SKYDEL-like, generated from first principles; real broadcast ephemerides)",
        title="Jammed GPS L1 C/A scenario (synthetic SKYDEL-like truth)",
        ephemerides=str(params["ephemerides"]),
        ephemerides_sha256=str(params["ephemerides_sha256"]),
        gps_week=int(win.week),
        t_start_sow=float(win.t_start),
        window_start_utc=utc_text(win.week, win.t_start, header.leap_seconds),
        window_fallback=int(win.fallback),
        window_reason=win.reason,
        window_max_gdop=float(win.max_gdop),
        duration_s=float(params["duration_s"]),
        receiver_lat_deg=float(rec["lat_deg"]),
        receiver_lon_deg=float(rec["lon_deg"]),
        receiver_height_m=float(rec["height_m"]),
        receiver_ecef_m=np.asarray(rx, dtype=float),
        carrier_hz=F_L1,
        code_period_s=CODE_PERIOD_S,
        cn0_clean_dbhz=float(params["cn0_dbhz"]),
        cn0_jammed_dbhz=cn0_jammed,
        jammer_onset_s=float(jam["onset_s"]),
        jammer_js_db=float(jam["js_db"]),
        jammer_bandwidth_hz=float(jam["bandwidth_hz"]),
        jammer_offset_hz=float(jam["offset_hz"]),
        spectral_separation_per_hz=float(kappa),
        clock=str(params["clock"]),
        truth_data_sets="; ".join(f"PRN {p}: IODE {win.data_sets[p].iode} t_oe {win.data_sets[p].t_oe:g}" for p in win.prns),
    )
    return ds
