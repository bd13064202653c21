"""Carrier trackers behind one interface: observations (trials, epochs) in,
dynamics-phase estimates (trials, epochs) out.

* :mod:`.base`: the :class:`~.base.Tracker` protocol, :class:`~.base.TrackerContext`,
  the dynamics model; :mod:`.blocks`: the numba building blocks (eqs. 8-14);
* :mod:`.registry`: type name -> tracker class, ``build``, ``label``, config validation;
* one module per tracker family: :mod:`.pll`, :mod:`.kf` (kf, akf, akf_ar),
  :mod:`.aekf_ar`; see ``docs/adding-a-tracker.md``.
"""
