"""An FLL-assisted third-order PLL as a scintrack plug-in tracker (entry point ``example_fll_pll``)."""

from .tracker import FllAssistedPll

__all__ = ["FllAssistedPll"]
