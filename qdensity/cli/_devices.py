"""The ``--mitigation`` / ``--postselect`` options of ``qdensity run`` and ``qdensity demo``
(the sampler engine's readout corrections); ``--target`` takes a name or a snapshot file."""

from __future__ import annotations

__all__ = ["correction_options", "corrections", "DEMO_OPTIONS"]


def correction_options(parser, target_help: str | None = None) -> None:
    """``--mitigation`` and ``--postselect`` (the sampler engine's readout corrections), and
    ``--target`` (default: the command's own) when ``target_help`` is given."""
    if target_help is not None:
        parser.add_argument("--target", help="the noisy device (default: heavy_hex): "
                            + target_help + "%(default).0s")
    parser.add_argument("--mitigation", choices=["m3"], default=None,
                        help="readout-error mitigation of every sampled circuit (mthree's M3, "
                             "calibrated on the target; calibration shots are counted apart; "
                             "default: none)%(default).0s")
    parser.add_argument("--postselect", choices=["hamming_weight"], default=None,
                        help="keep only shots of the Hamming weight the ideal circuit keeps "
                             "(unary models; default: none)%(default).0s")


#: ``qdensity demo`` options that change the ``DemoConfig`` when given.
DEMO_OPTIONS = ("seed", "budget", "shots", "target", "mitigation", "postselect")


def corrections(args) -> dict:
    """The engine keywords of ``--mitigation`` and ``--postselect``."""
    return {"mitigation": args.mitigation, "postselect": args.postselect}
