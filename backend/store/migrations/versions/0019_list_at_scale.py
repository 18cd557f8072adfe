"""The runs list at a lab's scale (issue 46): a narrow table for its search, and the indexes of its pages.

* ``job_search``: each job's name, notes and tags in one narrow row, lowered (``models.JobSearch``), filled
  here from every stored job in one statement; the listing's ``q`` reads it instead of every job's row.
* ``ix_jobs_system_created`` (system, created_at, id, status) in place of ``ix_jobs_system`` (system): a
  system's newest jobs are read in order and the page stops, instead of sorting every job of the system, and
  a count of a system's jobs of one status reads the index alone, no job's row.
* ``ix_job_summaries_max`` (algorithm, pct_of_max, job_id): a sort by % of max reads its index, as the two
  other result sorts read theirs.

On 100,000 stored jobs this takes seconds (docs/service.md, "The runs list at a lab's scale", gives the times
measured by ``benchmarks/bench_lab_scale.py --migrate``); nothing is written but the new table and indexes.

Revision ID: 0019
Revises: 0018
Create Date: 2026-12-02
"""

import sqlalchemy as sa
from alembic import op

revision = "0019"
down_revision = "0018"
branch_labels = None
depends_on = None

ID = sa.BigInteger().with_variant(sa.Integer, "sqlite")


def upgrade() -> None:
    op.create_table(
        "job_search",
        sa.Column("job_id", ID, sa.ForeignKey("jobs.id", ondelete="CASCADE"), primary_key=True),
        sa.Column("text", sa.Text(), nullable=False),
    )
    # name, notes, then each tag, joined by a newline and lowered (models.SEARCH_SEPARATOR; crud.search_text)
    if op.get_bind().dialect.name == "postgresql":
        tags = "string_agg(t.tag, E'\\n' ORDER BY t.tag)"
        newline = "E'\\n'"
    else:
        tags = "group_concat(t.tag, char(10))"
        newline = "char(10)"
    op.execute(
        f"INSERT INTO job_search (job_id, text) SELECT j.id, lower(j.name || {newline} || j.notes || "
        f"coalesce((SELECT {newline} || {tags} FROM job_tags t WHERE t.job_id = j.id), '')) FROM jobs j")
    op.create_index("ix_jobs_system_created", "jobs", ["system", "created_at", "id", "status"])
    op.drop_index("ix_jobs_system", table_name="jobs")
    op.create_index("ix_job_summaries_max", "job_summaries", ["algorithm", "pct_of_max", "job_id"])


def downgrade() -> None:
    op.drop_index("ix_job_summaries_max", table_name="job_summaries")
    op.create_index("ix_jobs_system", "jobs", ["system"])
    op.drop_index("ix_jobs_system_created", table_name="jobs")
    op.drop_table("job_search")
