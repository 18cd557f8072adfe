"""The database: engine and migrations, models, the job queue, data functions, and retries of long-lived processes."""
