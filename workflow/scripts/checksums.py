"""Checksum rule entry point: ``SHA256SUMS`` (sha256sum format) of the rule's inputs,
named relative to the manifest's folder."""

from scintrack import jobcode
from scintrack.checksums import write_checksums

sm = snakemake  # noqa: F821
log = jobcode.begin(sm, sm.rule)
path = write_checksums(sm.output[0], list(sm.input))
log.info("%s lists %d files", path, len(sm.input))
