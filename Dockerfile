# The service image: API, dashboard and local workers (`mgrao serve`), and in the cluster profile of
# docker-compose.yml also the migration, the dispatcher and the Dask scheduler and workers.
FROM python:3.11-slim
WORKDIR /app
COPY pyproject.toml README.md ./
COPY mgrao_core ./mgrao_core
COPY mgrao_cli ./mgrao_cli
COPY mgrao_client ./mgrao_client
COPY backend ./backend
COPY frontend ./frontend
COPY docs ./docs
COPY mgrao_docs ./mgrao_docs
RUN pip install --no-cache-dir ".[cluster]" && useradd --create-home mgrao && mkdir /data && chown mgrao /data
USER mgrao
ENV MGRAO_DATABASE_URL=sqlite:////data/mgrao.db
EXPOSE 8000
CMD ["mgrao", "serve", "--host", "0.0.0.0", "--port", "8000"]
