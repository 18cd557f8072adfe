"""The MG-RAO experiment service: REST API, job queue and local workers.

Grouped by concern, each layer importing only those below it:

* :mod:`backend.api`: the web edge (the app factory, routers, schemas, middleware, served files);
* :mod:`backend.services`: what the API computes from stored jobs (results, weights, studies);
* :mod:`backend.execution`: the processes that run jobs (local worker, Dask dispatcher, their lifecycle);
* :mod:`backend.store`: the database (models, migrations, the queue, data functions, retries);
* :mod:`backend.settings` and :mod:`backend.errors`, which every layer reads;
* :mod:`backend.processes`, where the processes that run jobs are wired to the studies.
"""
