"""Shipped agent configurations, tuned heuristic parameters and trained policies (data; installed as ``evertgym.shipped_agents``)."""
