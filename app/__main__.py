"""``python -m app``: serve the API with uvicorn on the configured host and port (``make serve``)."""

from __future__ import annotations

import uvicorn

from app.main import create_app
from app.settings import Settings


def main() -> None:
    settings = Settings()
    # log_config=None: uvicorn's loggers go through the JSON handler create_app installs; its access log
    # is off because app.request_log writes one richer event per request.
    # http and loop stay "auto": uvicorn takes httptools and uvloop (dependencies) when importable.
    uvicorn.run(
        create_app(settings), host=settings.host, port=settings.port, log_config=None, access_log=False
    )


if __name__ == "__main__":
    main()
