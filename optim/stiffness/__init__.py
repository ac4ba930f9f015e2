"""Stiffness design (issue 4): maximise K over (K, B) on the exact sampled-data boundary with CasADi."""

from optim.stiffness.design import Sensitivity, StiffnessDesign, design_stiffness
from optim.stiffness.requirements import StiffnessRequirements

__all__ = ["StiffnessDesign", "Sensitivity", "StiffnessRequirements", "design_stiffness"]
