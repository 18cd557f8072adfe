"""The MG-RAO experiment service: REST API, job queue and local workers."""
