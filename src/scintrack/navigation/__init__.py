"""Code tracking and positioning of the jammed GPS L1 C/A receiver (Zhao et al.).

* :mod:`.dll`: carrier-aided noncoherent early-minus-late delay lock loop run
  in closed loop against the correlator-level model
  (:mod:`scintrack.signals.gps.correlator`), with its closed-form thermal
  jitter and ramp lag;
* :mod:`.position`: iterative least-squares (Gauss-Newton) single-epoch fix
  with the Earth-rotation correction, DOP, and ENU errors.
"""
