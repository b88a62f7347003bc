"""The AP planner: multiagent, partially ordered plans with counterplanning.

The deliberative tier of the 3T architecture. One module per idea:

- ``problem``: :class:`PlanningProblem`, from ``.ap`` files (:func:`problem_from_program`)
  or PDDL (``pddl.load_pddl``);
- ``checks``: load-time checks with located errors;
- ``ground``: operators to ground actions; ``agents``: agent assignment;
- ``search``: greedy best-first search with hFF and helpful actions;
- ``partial_order``: deordering and the every-linearisation check;
- ``counterplan``: threats from uncontrolled agents, protection, risk;
- ``plan``: plot expansion, schedule, text/JSON (the DOT and PNG pictures are :mod:`atlas_rap.views`);
- ``dispatch``: which RAP executes each step; ``plan_file``: IPC plan files
  and an independent validator;
- ``solve``: all of it, end to end: :func:`solve`.

Nothing in ``sequencer/`` or below imports this package.
"""

from atlas_rap.planner.problem import PlanningProblem, problem_from_program
from atlas_rap.planner.solve import solve

__all__ = ["PlanningProblem", "problem_from_program", "solve"]
