"""TRMS closed-loop simulator with known ground truth (independent of the estimator's model code)."""
from .effects import EFFECTS
from .references import REFERENCES
from .simulate import SimResult, SimSettings, simulate

__all__ = ["EFFECTS", "REFERENCES", "SimResult", "SimSettings", "simulate"]
