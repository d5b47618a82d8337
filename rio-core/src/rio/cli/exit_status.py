"""How a workflow's end becomes the command's exit status: one table, one function, for every workflow command
(`rio teleop`, `rio deploy`, `rio replay`, `rio run`, `rio serve` and those plugins add through `finish`).

| status  | the run                                                                                        |
|---------|------------------------------------------------------------------------------------------------|
| 0       | ended as asked (the controller was done, the duration or the task's time limit passed), no node   |
|         | stopped, faulted or was stopped, and every arm followed its commands                             |
| 1       | did not start, or the command failed before it could run (one `error:` line)                     |
| 2       | a bad argument (one `error:` line naming the option)                                             |
| 3       | an arm was commanded to move and did not follow                                                 |
| 4       | a node stopped with an error during the run (a policy's NaN action, a crashed model, a lost device) |
| 5       | a node's device reported a fault, or its link dropped, during the run                           |
| 6       | a node was disabled by a safety stop during the run (an emergency stop, a watchdog, another client) |
| 128 + N | signal N ended a run that had none of the above (130 SIGINT, 143 SIGTERM, 129 SIGHUP)          |

When several apply the most serious wins, in the table's order from 4 to 6, then 3, then the signal: a run
that faulted and was then stopped with Ctrl+C exits 5, so a script learns that the run failed, not only how
it ended. The summary says all of it, what went wrong first (`RunSummary.events`); docs/controllers.md has
the same table.
"""

from __future__ import annotations

import signal
from typing import Any

#: The run's arm did not follow its commands.
EXIT_NOT_FOLLOWED = 3
#: A node stopped with an error during the run.
EXIT_NODE_ERROR = 4
#: A node's device reported a fault, or its link dropped, during the run.
EXIT_FAULT = 5
#: A node was disabled by a safety stop during the run.
EXIT_SAFETY_STOP = 6


def exit_code(summary: Any) -> int:
    """The exit status of a run that ended with `summary` (a `RunSummary`): the module's table."""
    problem = summary.problem
    if problem is not None:
        from rio.loop.summary import DISABLED, ERROR, FAULT, LINK  # here: rio.loop imports numpy (plugins list)

        return {ERROR: EXIT_NODE_ERROR, FAULT: EXIT_FAULT, LINK: EXIT_FAULT, DISABLED: EXIT_SAFETY_STOP}[problem]
    if not summary.followed:
        return EXIT_NOT_FOLLOWED
    if summary.signal:
        return 128 + int(getattr(signal, summary.signal, signal.SIGINT))
    return 0
