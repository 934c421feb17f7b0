"""The HTTP surface of the agent: FastAPI routes, schemas, the session store and limits (DESIGN.md §4)."""
