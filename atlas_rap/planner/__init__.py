"""The AP planner: multiagent, partially ordered plans with counterplanning.

(Filled in as the package grows; see the module docstrings.)
"""
