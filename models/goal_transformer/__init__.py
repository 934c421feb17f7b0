"""The JARVIS seed's Goal Transformer: explores toward a subgoal's object when the map has not seen it.

Modules: ``encoder`` (frozen EfficientNet-Lite0 frame features), ``model`` (the E.T.-style transformer and
its checkpoint files), ``dataset`` (search-phase episodes on disk), ``train``, ``evaluate``;
``python -m models.goal_transformer``. Nothing is imported here, so importing the package stays light.
"""
