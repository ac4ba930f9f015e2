"""Stability of the sampled wall loop: crossovers, K_cr, margins, passivity, the boundary, the 40-digit reference and the independent closed loop."""
