"""Driving the agent service over HTTP and scoring it as TEACh does: the ``client`` (and TEACh's
RemoteModel protocol), the ``service`` process, the episode ``runner`` with its ``metrics``, ``generated``
episodes, ``teach_remote`` (TEACh's own inference loop), and the command lines built on them: ``run_cli``
(``python -m harness run``), ``demo`` (with ``gif``) and ``evaluate`` (``python -m harness eval``)."""
