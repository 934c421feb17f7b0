"""One module per resource: sessions, steps, health."""
