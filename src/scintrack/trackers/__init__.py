"""Carrier trackers behind one interface: observations (trials, epochs) in,
dynamics-phase estimates (trials, epochs) out.  See :mod:`.base`."""
