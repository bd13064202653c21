"""Data rule entry point: the SKYDEL-like IQ recordings (clean and jammed segments) of the jammed GPS scenario."""

from scintrack import jobcode
from scintrack.data.gps_iq import iq_version
from scintrack.data.gps_iq_build import record, write
from scintrack.errors import InputError
from scintrack.io import open_dataset
from scintrack.pipeline.paths import IQ_SEGMENTS

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "gps_iq_recording")
params = dict(sm.params.iq)
version = iq_version(params)
if f"/{version}/" not in str(sm.output[0]):
    raise InputError(f"{sm.output[0]}: the config gives IQ version {version}; request that path")
ds = open_dataset(sm.input.dataset)
try:
    recorded = record(ds, params)
except ValueError as exc:
    raise InputError(f"gps_iq: {exc}") from None
written = write(recorded, {seg: sm.output[f"{seg}_data"] for seg in IQ_SEGMENTS})
for side in written.values():
    log.info("wrote %s: %d samples, scale %.4g, quantisation SNR %.1f dB, %d clipped, sha256 %s",
             side["data_file"], side["n_samples"], side["scale"], side["quantisation_snr_db"], side["clipped_values"], side["sha256"][:16])
