"""Studies and their results.

Revision ID: 0001
Revises:
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "studies",
        sa.Column("id", sa.String(36), primary_key=True),
        sa.Column("problem", sa.String(32), nullable=False),
        sa.Column("request", sa.JSON, nullable=False),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("total", sa.Integer, nullable=False),
        sa.Column("done", sa.Integer, nullable=False, server_default="0"),
        sa.Column("failed", sa.Integer, nullable=False, server_default="0"),
        sa.Column("created_at", sa.Float, nullable=False),
        sa.Column("run_started_at", sa.Float),
        sa.Column("run_start_done", sa.Integer, nullable=False, server_default="0"),
        sa.Column("finished_at", sa.Float),
        sa.Column("error", sa.Text),
    )
    op.create_index("ix_studies_status_created", "studies", ["status", "created_at"])
    op.create_table(
        "study_results",
        sa.Column("study_id", sa.String(36), sa.ForeignKey("studies.id", ondelete="CASCADE"), primary_key=True),
        sa.Column("point_hash", sa.String(32), primary_key=True),
        sa.Column("idx", sa.Integer, nullable=False),
        sa.Column("params", sa.JSON, nullable=False),
        sa.Column("result", sa.JSON),
        sa.Column("error", sa.Text),
    )
    op.create_index("ix_study_results_idx", "study_results", ["study_id", "idx"])


def downgrade() -> None:
    op.drop_index("ix_study_results_idx", "study_results")
    op.drop_table("study_results")
    op.drop_index("ix_studies_status_created", "studies")
    op.drop_table("studies")
