"""The TATC commander bot: TEACh's commander tools over the harness world, and episodes over HTTP.

``tools``: ProgressCheck, SearchObject, SelectOid; ``bot``: the commander that answers the follower with
the next step at one of three information levels (the JARVIS seed's Table 2); ``episode``: one TATC
episode against the follower service; ``__main__`` (``python -m harness commander``): run one from the
command line. May import the rest of ``harness`` and ``symbolic``; never ``agent``, ``app`` or ``models``.
"""
