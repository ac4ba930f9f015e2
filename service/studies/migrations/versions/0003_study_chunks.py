"""Results in blocks (issue 20): one row per chunk of consecutive points, its results one Arrow IPC blob.

The per-point rows of ``study_results`` are converted (runs of consecutive points, at most 4096 per block,
exactly the values they held) and the table is dropped: an old store opens with every stored point kept,
and a resumed study plans only the points no block covers.

Revision ID: 0003
Revises: 0002
"""

from __future__ import annotations

import json

import numpy as np
import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None

_RUN = 4096


def _json(value):
    return json.loads(value) if isinstance(value, (str, bytes)) else value


def upgrade() -> None:
    from service.studies.blocks import encode_block

    chunks = op.create_table(
        "study_chunks",
        sa.Column("study_id", sa.String(36), sa.ForeignKey("studies.id", ondelete="CASCADE"), primary_key=True),
        sa.Column("start", sa.BigInteger, primary_key=True, autoincrement=False),
        sa.Column("n", sa.Integer, nullable=False),
        sa.Column("failed", sa.Integer, nullable=False),
        sa.Column("chunk_hash", sa.String(32), nullable=False),
        sa.Column("data", sa.LargeBinary, nullable=False),
    )
    conn = op.get_bind()
    old = sa.table("study_results", sa.column("study_id"), sa.column("idx"), sa.column("params"),
                   sa.column("result"), sa.column("error"))
    ids = conn.execute(sa.select(old.c.study_id).distinct()).scalars().all()

    def flush(sid, run):
        values = np.array([r[1] for r in run], dtype=float).reshape(len(run), -1)
        block = encode_block(run[0][0], values, [r[2] for r in run], [r[3] for r in run])
        conn.execute(chunks.insert().values(study_id=sid, start=block.start, n=block.n, failed=block.failed,
                                            chunk_hash=block.digest, data=block.data))

    for sid in ids:
        last, run = -1, []
        while True:
            rows = conn.execute(sa.select(old.c.idx, old.c.params, old.c.result, old.c.error)
                                .where(old.c.study_id == sid, old.c.idx > last).order_by(old.c.idx)
                                .limit(_RUN)).all()
            if not rows:
                break
            for idx, params, result, error in rows:
                if run and (idx != run[-1][0] + 1 or len(run) >= _RUN):
                    flush(sid, run)
                    run = []
                run.append((int(idx), [float(v) for v in _json(params)], _json(result), error))
            last = rows[-1][0]
        if run:
            flush(sid, run)
    op.drop_index("ix_study_results_idx", "study_results")
    op.drop_table("study_results")


def downgrade() -> None:
    raise NotImplementedError("results stored in blocks are not converted back to one row per point")
