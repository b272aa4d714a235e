# hydrodiag service.
#   docker build -t hydrodiag .
#   docker run -p 8000:8000 -v hydrodiag-data:/data hydrodiag
# The first start writes an API key to /data/first-api-key (mode 0600; `docker logs` shows
# its path, not the key: docker exec CONTAINER cat /data/first-api-key); the store lives in /data.
# tests/app/test_dockerfile.py follows the COPY, RUN, CMD and HEALTHCHECK steps below in a
# fresh virtual environment: keep RUN steps to `pip install` and user/folder set-up.
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    HYDRODIAG_DATA_DIR=/data \
    HYDRODIAG_HOST=0.0.0.0 \
    HYDRODIAG_PORT=8000 \
    MALLOC_ARENA_MAX=2

WORKDIR /opt/hydrodiag
COPY pyproject.toml README.md ./
COPY sim/ sim/
COPY diagnostics/ diagnostics/
COPY app/ app/
RUN pip install .
RUN useradd --system --uid 10001 --user-group --no-create-home --home-dir /data hydrodiag \
    && mkdir -p /data \
    && chown hydrodiag:hydrodiag /data

USER hydrodiag
WORKDIR /data
VOLUME ["/data"]
EXPOSE 8000

HEALTHCHECK --interval=30s --timeout=5s --start-period=30s --retries=3 \
    CMD ["python", "-c", "import os, urllib.request; urllib.request.urlopen('http://127.0.0.1:%s/health' % os.environ.get('HYDRODIAG_PORT', '8000'), timeout=4)"]

# `serve` migrates the store, preloads the reference rig, then starts uvicorn.
CMD ["hydrodiag", "serve"]
