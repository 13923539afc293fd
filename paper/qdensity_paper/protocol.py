"""The paper's own protocol for an experiment: ``qdensity experiment NAME --paper``.

Each experiment with a counterpart in the paper carries a :class:`PaperProtocol`: the settings
the paper states (sizes, qubits, epochs, optimiser and learning rate, batch size, noise), which
of them the paper fixes, the readings of the places where the paper is ambiguous (both run, as
settings), and where even this mode departs from the paper (``departures``). The verdict rule
(:mod:`qdensity_paper.verdicts`) calls a comparison *not comparable* when a departure
changes the question.

A ``--paper`` run refuses an override of a fixed setting (``--set epochs=3``): a run with it is
no longer the paper's protocol; ``--full --set ...`` runs it as a departure under its own name.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = ["PaperProtocol", "Departure", "resolve_paper"]


@dataclass(frozen=True)
class Departure:
    """One place where a run departs from the paper.

    Attributes
    ----------
    text : str
        What departs and why, one sentence.
    touches : tuple of str
        Keys of the claims (:data:`qdensity_paper.claims.CLAIMS`) whose question it
        changes (``"*"``: every claim of the experiment); the verdict rule calls those claims
        *not comparable*. Empty: listed, but no claim's question changes.
    applies : callable, optional
        ``applies(result) -> bool``: whether a given results file has the departure (an older
        file may, the present code not); None: every run of the mode has it.
    """

    text: str
    touches: tuple[str, ...] = ()
    applies: Any = None

    def touches_claim(self, key: str) -> bool:
        return "*" in self.touches or key in self.touches


@dataclass(frozen=True)
class PaperProtocol:
    """The paper's settings for one experiment.

    Attributes
    ----------
    settings : dict
        Every setting of the experiment (the same keys as its ``quick`` and ``full``), at the
        paper's values where the paper states them.
    fixed : tuple of str
        Keys whose value the paper states; ``--paper`` refuses to override them.
    readings : dict
        Setting -> the paper's words where it is ambiguous; such a setting takes each reading
        (its value in ``settings`` runs both where the experiment can).
    departures : tuple of Departure
        Where this mode still departs from the paper (data the paper used that qdensity
        cannot ship, a read-out, ...), each with the claims it touches; a plain string is a
        departure that touches none.
    source : str
        Where in the paper the settings are stated.
    """

    settings: Mapping[str, Any]
    fixed: tuple[str, ...] = ()
    readings: Mapping[str, str] = field(default_factory=dict)
    departures: tuple[Departure | str, ...] = ()
    source: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "departures", tuple(
            d if isinstance(d, Departure) else Departure(str(d)) for d in self.departures))
        unknown = sorted(set(self.fixed) - set(self.settings))
        if unknown:
            raise ValueError(f"fixed names settings {unknown} that the protocol lacks; known: "
                             f"{sorted(self.settings)}")
        overlap = sorted(set(self.fixed) & set(self.readings))
        if overlap:
            raise ValueError(f"settings {overlap} are both fixed and ambiguous; the paper "
                             "either states them or leaves them open")


def check_overrides(name: str, base: Mapping, config) -> None:
    """Refuse ``config`` unless it is a mapping of settings that ``base`` has.

    Raises
    ------
    TypeError
        ``config`` not a mapping.
    ValueError
        A setting ``base`` does not have (the message lists the known ones).
    """
    if not isinstance(config, Mapping):
        raise TypeError(f"config must be a mapping of settings, got {type(config).__name__}")
    unknown = sorted(set(config) - set(base))
    if unknown:
        raise ValueError(f"config has unknown settings {unknown} for experiment {name!r}; "
                         f"known: {sorted(base)}")


def resolve_paper(name: str, protocol: PaperProtocol | None, config: Mapping | None) -> dict:
    """The ``--paper`` settings of experiment ``name`` with ``config``'s overrides.

    Parameters
    ----------
    name : str
        Experiment name (for messages).
    protocol : PaperProtocol or None
        The experiment's protocol; None for an experiment beyond the paper's numerics.
    config : mapping, optional
        Overrides; only settings the paper does not fix.

    Returns
    -------
    dict
        The settings to run.

    Raises
    ------
    ValueError
        An experiment without a paper protocol, an unknown setting, or an override of a setting
        the paper fixes (the message names it, the paper's value and the way to run it anyway).
    TypeError
        ``config`` not a mapping.
    """
    if protocol is None:
        raise ValueError(f"experiment {name!r} has no --paper mode: the paper has no such "
                         "experiment; run --quick or --full")
    base = dict(protocol.settings)
    if config is None:
        return base
    check_overrides(name, base, config)
    fixed = [k for k in sorted(config) if k in protocol.fixed and config[k] != base[k]]
    if fixed:
        stated = ", ".join(f"{k}={base[k]!r}" for k in fixed)
        raise ValueError(f"--paper fixes {stated} ({protocol.source or 'the paper'}); a run "
                         f"with another value is not the paper's protocol: run --full with "
                         f"--set instead. Settings --paper leaves open: "
                         f"{sorted(set(base) - set(protocol.fixed))}")
    base.update(config)
    return base
