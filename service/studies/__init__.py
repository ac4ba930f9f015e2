"""Batch design-space studies: the store (SQLAlchemy + Alembic), the runner and its executors.

The numerics of a study (sweeps, points, problem functions) are in ``optim.studies.problems``; this
package only persists, schedules and serves them.
"""
