"""Batch design-space studies: problems evaluated point by point or a chunk at once."""
