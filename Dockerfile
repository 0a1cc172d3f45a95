# One image for the simulator, the agent and the rerun web viewer (the router uses the official Zenoh image).
FROM python:3.11-slim
WORKDIR /app
COPY pyproject.toml README.md ./
COPY sim sim
COPY ident ident
COPY detect detect
COPY bridge bridge
COPY agent agent
COPY quantify quantify
COPY schemas schemas
COPY stiction stiction
COPY trainer trainer
COPY bench bench
RUN pip install --no-cache-dir '.[viewer,opcua]' && rerun analytics disable || true
ENTRYPOINT []
