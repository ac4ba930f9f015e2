"""Alembic environment of the study store, applied programmatically at startup (store.migrate)."""
