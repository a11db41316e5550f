"""One frozen configuration for random robots and the reproduction operators (paper, Table 1)."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from revolve_env.body.validate import Limits

__all__ = ["DRAW_SIGMAS", "MAX_DRAW", "MAX_INT", "MIN_RANDOM_ROBOT_RETRIES", "EvolutionConfig"]

_PROBABILITIES = (
    "p_remove_subtree",
    "p_duplicate_subtree",
    "p_swap_subtree",
    "p_remove_hidden_neuron",
    "p_remove_connection",
    "initial_connection_density",
)
_POSITIVE_INTS = (
    "max_parts",
    "min_parts",
    "max_random_robot_retries",
    "max_placement_attempts",
    "operator_attempts",
)
_NON_NEGATIVE_INTS = ("max_inputs", "max_outputs", "max_hidden")

MAX_INT = 2**31 - 1
"""Largest value of any integer field: counts beyond it cannot run (the compiled controller
indexes neurons with 32-bit integers, NumPy clips part counts as 64-bit ones)."""

MAX_DRAW = 2.0**53
"""Largest part or hidden-neuron count a random draw may reach: floats stop being exact integers
here, and a draw of N(mean, sd) beyond the float range is inf, which ``round`` cannot turn into a
count (``initial_parts_sd=1e308`` raised OverflowError in ``random_robot``)."""

DRAW_SIGMAS = 40.0
"""How many standard deviations a normal draw is assumed to reach (NumPy's generator does not
exceed about 9 in 10**18 draws; 40 is a wide margin)."""

MIN_RANDOM_ROBOT_RETRIES = 10
"""Fewest whole-robot attempts :func:`evolution.random_robot.random_robot` may be given.

Growing a random robot fails now and then (a drawn size that overlapping placements do not let it
reach). Measured with the Table 1 limits and ``max_placement_attempts=200``, 150 robots per mean:
an attempt fails 0.7 % of the time at ``initial_parts_mean=3``, 2.0 % at 12 and 4.5 % at 30, and
38 % at 30 with ``max_placement_attempts=1``. With one attempt a 30-part mean loses about one
robot in 22, so a 100-robot initial population fails (RandomRobotError) 99 % of the time; with 10,
even an attempt that fails 20 % of the time loses one robot in 10 million.
"""


def _described(value: object) -> str:
    """``value`` for an error message, saying so when it is a boolean (``True`` reads like 1)."""
    return f"the boolean {value!r}" if isinstance(value, bool) else repr(value)


@dataclass(frozen=True, slots=True)
class EvolutionConfig:
    """Parameters of random robot generation and reproduction.

    Defaults are the paper's Table 1 where it gives a value, otherwise the values of the issue.
    Construction refuses, with a ValueError naming the field, any value that cannot run: wrong
    types (a boolean where a number is expected included), values out of range, part-count
    distributions whose draws overflow, and retry budgets too small to grow a population.

    Attributes:
        max_parts: Most parts in a robot, core included.
        min_parts: Fewest parts; subtree removal never goes below it.
        max_inputs: Most sensor values (the core's 6 IMU values included).
        max_outputs: Most actuators (active hinges).
        max_hidden: Most hidden neurons.
        initial_parts_mean: Mean of the number of parts of a random robot, N(mean, sd) clipped
            to ``[min_parts, max_parts]``.
        initial_parts_sd: Standard deviation of that number. ``initial_parts_mean`` plus
            :data:`DRAW_SIGMAS` of these must stay below :data:`MAX_DRAW`.
        initial_hidden_mean: Mean number of hidden neurons of a random robot (Poisson, clipped to
            ``max_hidden``). Parts added by mutation get hidden neurons at the same rate per part.
        initial_connection_density: Probability that each allowed ``src -> dst`` pair is
            connected in a random robot (and between a newly added part and the rest).
        p_remove_subtree: Probability of removing a random subtree.
        p_duplicate_subtree: Probability of duplicating a random subtree onto a free slot.
        p_swap_subtree: Probability of swapping two unrelated subtrees.
        p_remove_hidden_neuron: Probability that each hidden neuron is removed. New ones are then
            added at the rate that balances the removals at a random robot's brain size (see
            :func:`evolution.operators.mutate_brain_structure`), so brain size does not drift.
        p_remove_connection: Same for each connection.
        mutation_sigma: Standard deviation of the Gaussian perturbation of every continuous
            parameter (part parameters, neuron parameters, weights), as a fraction of the
            parameter's allowed range. Results are clipped to the range.
        balance_by_removal: The paper adds a random part with an expected count equal to the
            expected parts removed by subtree removal minus those added by duplication. With the
            Table 1 values that difference is negative (duplication is twice as likely), so the
            body would grow to ``max_parts``. When True, a negative difference removes that many
            random leaves instead, which keeps the expected body size constant; when False the
            paper's rule is applied literally (nothing happens when it is negative).
        max_random_robot_retries: Whole-robot attempts before :func:`random_robot` gives up; at
            least :data:`MIN_RANDOM_ROBOT_RETRIES`.
        max_placement_attempts: Failed part placements (overlaps, full slots) tolerated per
            random robot attempt.
        operator_attempts: Random choices an operator tries before it skips (a choice is
            rejected when the result would not be constructible).
    """

    max_parts: int = 30
    min_parts: int = 3
    max_inputs: int = 10
    max_outputs: int = 10
    max_hidden: int = 10
    initial_parts_mean: float = 12.0
    initial_parts_sd: float = 5.0
    initial_hidden_mean: float = 3.0
    initial_connection_density: float = 0.25
    p_remove_subtree: float = 0.05
    p_duplicate_subtree: float = 0.1
    p_swap_subtree: float = 0.05
    p_remove_hidden_neuron: float = 0.05
    p_remove_connection: float = 0.05
    mutation_sigma: float = 0.1
    balance_by_removal: bool = True
    max_random_robot_retries: int = 20
    max_placement_attempts: int = 200
    operator_attempts: int = 10

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name in _POSITIVE_INTS or f.name in _NON_NEGATIVE_INTS:
                if not isinstance(value, int) or isinstance(value, bool):
                    raise ValueError(f"EvolutionConfig.{f.name} must be an int, got "
                                     f"{_described(value)}")
                low = 1 if f.name in _POSITIVE_INTS else 0
                if value < low:
                    raise ValueError(f"EvolutionConfig.{f.name} must be >= {low}, got {value!r}")
                if value > MAX_INT:
                    raise ValueError(
                        f"EvolutionConfig.{f.name} must be <= {MAX_INT}, got {value!r}")
            elif f.type in ("float", float):
                if (
                    not isinstance(value, (int, float))
                    or isinstance(value, bool)
                    or not math.isfinite(value)
                ):
                    raise ValueError(f"EvolutionConfig.{f.name} must be a finite number, got "
                                     f"{_described(value)}")
                if f.name in _PROBABILITIES and not 0.0 <= value <= 1.0:
                    raise ValueError(
                        f"EvolutionConfig.{f.name} is a probability and must be in [0, 1], "
                        f"got {value!r}"
                    )
                if value < 0:
                    raise ValueError(f"EvolutionConfig.{f.name} must be >= 0, got {value!r}")
            elif f.name == "balance_by_removal" and not isinstance(value, bool):
                raise ValueError(
                    f"EvolutionConfig.balance_by_removal must be a bool, got {value!r}")
        if self.min_parts > self.max_parts:
            raise ValueError(
                f"EvolutionConfig.min_parts ({self.min_parts}) is greater than max_parts "
                f"({self.max_parts})"
            )
        if self.max_inputs < 6:
            raise ValueError(
                f"EvolutionConfig.max_inputs must be >= 6 (the core's IMU values), got "
                f"{self.max_inputs}"
            )
        if self.initial_parts_sd == 0 and not (
            self.min_parts <= self.initial_parts_mean <= self.max_parts
        ):
            raise ValueError("EvolutionConfig.initial_parts_mean is outside [min_parts, max_parts]")
        reach = self.initial_parts_mean + DRAW_SIGMAS * self.initial_parts_sd
        if not reach < MAX_DRAW:
            field = ("initial_parts_sd" if self.initial_parts_mean < MAX_DRAW
                     else "initial_parts_mean")
            raise ValueError(
                f"EvolutionConfig.{field}: the part count N({self.initial_parts_mean!r}, "
                f"{self.initial_parts_sd!r}) overflows; initial_parts_mean + "
                f"{DRAW_SIGMAS:g} * initial_parts_sd must be below 2**53"
            )
        if not self.initial_hidden_mean < MAX_DRAW:
            raise ValueError(
                "EvolutionConfig.initial_hidden_mean must be below 2**53 (a Poisson mean NumPy "
                f"can draw from), got {self.initial_hidden_mean!r}"
            )
        if self.max_random_robot_retries < MIN_RANDOM_ROBOT_RETRIES:
            raise ValueError(
                f"EvolutionConfig.max_random_robot_retries must be >= {MIN_RANDOM_ROBOT_RETRIES}, "
                f"got {self.max_random_robot_retries}: so few attempts leave a random robot of "
                f"mean {self.initial_parts_mean:g} parts a real chance to fail, and one failure "
                "stops the run (RandomRobotError)"
            )
        if self.mutation_sigma > 1.0:
            raise ValueError(
                f"EvolutionConfig.mutation_sigma is a fraction of each range and must be <= 1, "
                f"got {self.mutation_sigma!r}"
            )

    @property
    def limits(self) -> Limits:
        """The robot limits of this configuration for ``validate``."""
        return Limits(
            max_parts=self.max_parts,
            max_inputs=self.max_inputs,
            max_outputs=self.max_outputs,
            max_hidden=self.max_hidden,
        )
