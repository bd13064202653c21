"""Result rule entry point: spectra (raw and despread) of the clean and jammed IQ recordings."""

from scintrack import jobcode
from scintrack.data.gps_iq_build import sv_signal
from scintrack.experiments.iq_spectrum import spectra
from scintrack.io import open_dataset, provenance, write_netcdf
from scintrack.pipeline.paths import IQ_SEGMENTS
from scintrack.signals.gps.iq import FULL_SCALE, read_recording

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "zhao_iq_spectrum")
params = dict(sm.params.spectrum)
ds = open_dataset(sm.input.dataset)
segments, truth = {}, {}
for seg in IQ_SEGMENTS:
    samples, sidecar = read_recording(sm.input[f"{seg}_data"])  # int16 / scale
    segments[seg] = (samples * (sidecar["scale"] / FULL_SCALE), sidecar)  # back to full-scale units
    sv = sv_signal(ds, 0, float(sidecar["segment_start_s"]), 1)
    truth[seg] = (float(sv.code_phase_chips[0]), float(sv.doppler_hz[0]))
out = spectra(segments, truth, int(ds["prn"].values[0]), params["welch_nperseg"], IQ_SEGMENTS)
out.attrs.update(provenance(config=params, inputs=[sm.input[f"{s}_data"] for s in IQ_SEGMENTS]))
digest = write_netcdf(out, sm.output[0])
log.info("wrote %s (content sha256 %s)", sm.output[0], digest)
