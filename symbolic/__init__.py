"""The symbolic core: ontology, subgoal grammar, beliefs, Table 5 predicates and task-level repair.

Pure Python (stdlib only) so the harness, the agent and the models can all share it; nothing is loaded at
import time (``symbolic.ontology.load_ontology()`` reads the table on first use).
"""
