"""Susi 2014 rule entry point: the REAL Septentrio index rows (BiScEF, both stations) and the pre-declared event.

Reads each BiScEF file after checking its sha256 against the registry, keeps
the GPS L1 C/A rows at elevation >= the mask (:mod:`scintrack.data.biscef`)
and records the minute with the largest Phi60 among them in the attributes
(``event_*``).
"""

from scintrack import jobcode
from scintrack.data.biscef import check_sha256, combine, load, select, strongest_minute
from scintrack.io import provenance, write_netcdf

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, "susi_biscef_indices")
run = sm.params.run
mask = float(run["elevation_min_deg"])
parts = []
for entry, spec in run["files"].items():
    path = sm.input[entry]
    check_sha256(path, spec["sha256"], entry)
    station = load(path)
    parts.append(select(station, mask))
    log.info("%s (%s): %d GPS satellite-minutes, %d at elevation >= %g deg", path, station.attrs["station_name"], station.sizes["row"],
             parts[-1].sizes["row"], mask)
ds = combine(parts)
event = strongest_minute(ds)
ds.attrs.update({f"event_{key}": value for key, value in event.items()})
ds.attrs.update({
    "title": "REAL Septentrio scintillation indices (BiScEF, Tromso and Ny-Alesund, 2023-01-15), GPS L1 C/A, "
             f"elevation >= {mask:g} deg, and the minute with the largest Phi60",
    "event_rule": f"the minute with the largest L1 Phi60 of a GPS satellite at elevation >= {mask:g} deg over both files "
                  "(docs/REPRODUCTION.md, Real index data)",
    "source": "kartverket/BiScEF ExampleEvents/20230113to20230115 at commit 1c1f345d8b563ad4c81f8dd58bd88070fc207a41 (MIT)",
})
ds.attrs.update(provenance(config=run, inputs=list(sm.input)))
write_netcdf(ds, sm.output[0])
log.info("event: %s PRN %d %s UTC, elevation %.1f deg: Phi60 %.3f rad, S4 %.3f, T %.3g rad^2/Hz, p %.2f, C/N0 %.1f dB-Hz",
         event["station_name"], event["prn"], event["time_utc"], event["elevation"], event["phi60"], event["s4"], event["T"], event["p"],
         event["cn0"])
