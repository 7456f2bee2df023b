"""Draw the paper's Fig. 2 regime map: velocity over (f, a) with a*_pm and lift-off.

Usage: ``python -m study.figures.regime_map --output figures/regime_map.png``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import TwoSlopeNorm

import study


def draw(structure: study.Structure, f, a, output: Path) -> Path:
    """Solve the map and write it as an image.

    Parameters
    ----------
    structure : study.Structure
        The structure.
    f : numpy.ndarray
        Drive frequencies [Hz], 1-D.
    a : numpy.ndarray
        Drive accelerations [m s^-2], 1-D.
    output : pathlib.Path
        Image file to write (format from its suffix).

    Returns
    -------
    pathlib.Path
        ``output``.
    """
    velocity, status = study.steady_velocity(structure, f[None, :], a[:, None])
    a_plus, a_minus = study.thresholds(structure, f)
    a_lift = study.lift_off_acceleration(structure, f)
    fig, ax = plt.subplots(figsize=(7.0, 4.8), layout="constrained")
    mm_per_s = 1e3 * np.where(status == study.Status.LIFT_OFF, np.nan, velocity)
    limit = np.nanmax(np.abs(mm_per_s)) or 1.0
    mesh = ax.pcolormesh(
        f, a, mm_per_s, cmap="RdBu", norm=TwoSlopeNorm(0.0, -limit, limit), shading="auto"
    )
    fig.colorbar(mesh, ax=ax, label="mean velocity v [mm s$^{-1}$]")
    ax.plot(f, a_plus, color="tab:blue", lw=1.5, label="$a^*_+$ (forward slips start)")
    ax.plot(f, a_minus, color="tab:red", lw=1.5, label="$a^*_-$ (backward slips start)")
    ax.plot(f, a_lift, color="k", ls="--", lw=1.2, label="lift-off (model invalid above)")
    lifted = np.where(status == study.Status.LIFT_OFF, 1.0, np.nan)
    ax.pcolormesh(f, a, lifted, cmap="Greys", vmin=0, vmax=4, shading="auto", alpha=0.6)
    ax.set(
        xlim=(f[0], f[-1]),
        ylim=(a[0], a[-1]),
        xlabel="drive frequency f [Hz]",
        ylabel="drive acceleration a [m s$^{-2}$]",
        title=(
            f"Steady velocity: f0={structure.f0} Hz, Q={structure.Q}, "
            f"alpha={structure.alpha} deg, M={structure.M}, cs={structure.cs}"
        ),
    )
    ax.title.set_fontsize(10)
    ax.legend(loc="lower left", fontsize=8)
    output.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(output, dpi=150, metadata={"Description": repr(structure)})
    plt.close(fig)
    return output


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=Path("figures/regime_map.png"))
    parser.add_argument("--num-f", type=int, default=501)
    parser.add_argument("--num-a", type=int, default=301)
    args = parser.parse_args(argv)
    structure = study.Structure(f0=14.44, Q=17.5, alpha=64.0, M=0.08, cs=0.25)
    f = np.linspace(10.0, 20.0, args.num_f)
    a = np.linspace(0.0, 12.0, args.num_a)
    print(f"wrote {draw(structure, f, a, args.output)}")


if __name__ == "__main__":
    main()
