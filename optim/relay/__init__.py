"""The relay experiment on a sampled loop and every cycle it admits."""
