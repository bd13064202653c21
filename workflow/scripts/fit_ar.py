"""AR rule entry point: fit AR models to one training dataset, with the phase unwrapped and (reading R5) wrapped."""

from scintrack import jobcode
from scintrack.io import open_dataset, provenance, write_netcdf
from scintrack.models.lut import fit_training_set

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "ar_fit")
train = open_dataset(sm.input.train)
for output, params, wrapped in ((sm.output.unwrapped, sm.params.fit, False), (sm.output.wrapped, sm.params.fit_wrapped, True)):
    ar = params["ar_models"]
    # the wrapped fits take the amplitude fits (the same series) from the unwrapped ones, as written
    reuse = open_dataset(sm.output.unwrapped) if wrapped else None
    fits = fit_training_set(train, ar["max_order"], ar["pacf_lags"], ar["pacf_alpha"], ar["pacf_lengths_s"], wrap_phase=wrapped, reuse=reuse,
                            progress=log.info)
    if wrapped:
        fits.attrs["phase_fitted"] = "wrapped angle(exp(j theta)) (reading R5)"
    inputs = [sm.input.train, sm.output.unwrapped] if wrapped else [sm.input.train]
    fits.attrs.update(provenance(config=params, inputs=inputs))
    fits.attrs["ts"] = train.attrs["ts"]
    write_netcdf(fits, output)
    log.info("fitted %s (%s phase)", sm.input.train, "wrapped" if wrapped else "unwrapped")
