"""What the figures share: saving as PNG and PDF with provenance in the metadata, the
structure a file was computed for, the paper's regime points, and a few checks."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from study.status import Status

__all__ = [
    "PAPER_POINTS",
    "VALID",
    "coupling_label",
    "grid_minimum",
    "one_way_velocity",
    "parameter_text",
    "provenance_line",
    "save",
    "single_structure",
    "structure_from_dataset",
]


def provenance_line(dataset: xr.Dataset) -> str:
    """One line naming the data a figure came from (study, spec hash, fingerprint)."""
    attrs = dataset.attrs
    return (
        f"data: study '{attrs.get('study_name')}', spec sha256 "
        f"{attrs.get('study_spec_sha256', '?')}, fingerprint "
        f"{attrs.get('study_fingerprint', '?')}, created {attrs.get('date_created', '?')} "
        f"by study {attrs.get('study_version', '?')}"
    )


def save(fig: plt.Figure, output: str | Path, dataset: xr.Dataset, title: str) -> list[Path]:
    """Write ``output.png`` and ``output.pdf`` with the data's provenance in their metadata.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure (closed afterwards).
    output : path
        File stem; a ``.png``/``.pdf`` suffix is replaced.
    dataset : xarray.Dataset
        The result file's dataset the figure was drawn from.
    title : str
        What the figure shows (also its metadata title).

    Returns
    -------
    list of pathlib.Path
        The PNG and the PDF.
    """
    stem = Path(output)
    if stem.suffix in (".png", ".pdf"):
        stem = stem.with_suffix("")
    stem.parent.mkdir(parents=True, exist_ok=True)
    source = provenance_line(dataset)
    written = []
    png = stem.with_suffix(".png")
    fig.savefig(png, dpi=150, metadata={
        "Title": title,
        "Description": source,
        "Source": f"study_spec_sha256={dataset.attrs.get('study_spec_sha256', '')}",
        "Software": f"study {dataset.attrs.get('study_version', '')}",
    })
    written.append(png)
    pdf = stem.with_suffix(".pdf")
    fig.savefig(pdf, metadata={
        "Title": title,
        "Subject": source,
        "Keywords": f"study_spec_sha256={dataset.attrs.get('study_spec_sha256', '')}",
        "Creator": f"study {dataset.attrs.get('study_version', '')}",
    })
    written.append(pdf)
    plt.close(fig)
    return written


def structure_from_dataset(dataset: xr.Dataset, **at: int):
    """The :class:`study.Structure` a result was computed for.

    Fixed parameters come from the file's scalar coordinates; for a swept one give
    its index, e.g. ``structure_from_dataset(ds, M=3)`` (``m_add`` for mass studies).
    """
    import study

    params = {}
    for name in ("f0", "Q", "alpha", "M", "cs", "ck", "g"):
        if name in dataset.coords and dataset[name].ndim == 0:
            params[name] = float(dataset[name])
    for name, index in at.items():
        params[name] = float(dataset[name].values[index])
        if name == "m_add":
            params["M"] = float(dataset["M"].values[index])
            del params["m_add"]
    if "ck" not in params and "cs" in params:
        params["ck"] = params["cs"]
    return study.Structure(**params)


#: The paper's points in its regions S, P, N and PN: name -> (f [Hz], a [m s^-2]).
PAPER_POINTS: dict[str, tuple[float, float]] = {
    "S": (13.0, 5.0),
    "P": (13.0, 8.5),
    "N": (16.5, 8.5),
    "PN": (14.6, 7.0),
}

#: Statuses with a valid velocity (0 when static).
VALID = (Status.STATIC, Status.STICK_SLIP, Status.CONTINUOUS_SLIDING)


def single_structure(dataset: xr.Dataset, figure: str) -> None:
    """Refuse a file that sweeps structure parameters (the figure draws one structure).

    Raises
    ------
    FigureError
        Naming the swept parameters.
    """
    from study.figures import FigureError

    swept = [str(d) for d in dataset.dims if d not in ("f", "a", "branch")]
    if swept:
        raise FigureError(
            f"figure {figure!r} draws a single structure, but this file (study "
            f"{dataset.attrs.get('study_name')!r}) sweeps {', '.join(swept)}; draw it from "
            "a file with fixed structure parameters"
        )


def coupling_label(dataset: xr.Dataset) -> str:
    """Which coupling (and solver) computed the file's velocities, for titles.

    From the file's ``study_coupling`` and ``study_solver_method`` attributes: the
    paper's one-way model, or two-way coupling in which the sliding base also forces
    the plate's mode.
    """
    coupling = str(dataset.attrs.get("study_coupling", "one-way"))
    method = str(dataset.attrs.get("study_solver_method", "exact"))
    if coupling == "two-way":
        text = "two-way coupling (the sliding base also forces the mode)"
    else:
        text = "one-way coupling (the paper's model)"
    return text + (", time integration" if method == "integrator" else "")


def one_way_velocity(dataset: xr.Dataset, *order: str) -> np.ndarray | None:
    """The paper's one-way velocity held beside a two-way study (``paper_model``),
    NaN where that model does not move, transposed to ``order``; None if absent."""
    if "velocity_one_way" not in dataset or "status_one_way" not in dataset:
        return None
    velocity = dataset["velocity_one_way"].transpose(*order).values
    status = dataset["status_one_way"].transpose(*order).values
    moving = np.isin(status, (Status.STICK_SLIP, Status.CONTINUOUS_SLIDING))
    return np.where(moving & (velocity != 0), velocity, np.nan)


def parameter_text(dataset: xr.Dataset) -> str:
    """The structure's parameters, compactly, from the file's scalar coordinates."""
    s = structure_from_dataset(dataset)
    text = (
        f"$f_0$ = {s.f0:g} Hz, Q = {s.Q:g}, $\\alpha$ = {s.alpha:g}°, M = {s.M:g}, "
        f"$c_s$ = {s.cs:g}"
    )
    if s.ck != s.cs:
        text += f", $c_k$ = {s.ck:g}"
    if s.g != 9.8:
        text += f", g = {s.g:g} m s$^{{-2}}$"
    return text


#: The f grid resolves a threshold minimum when its step is below f0 / (RESOLUTION Q):
#: the nearest grid point is then within f0 / (20 Q) of the minimum, where the mode's
#: gain has dropped by less than 0.5 %.
RESOLUTION = 10.0


def grid_minimum(f: np.ndarray, curve: np.ndarray, f0: float, Q: float) -> tuple[int, bool]:
    """Index of the lowest value of ``curve`` over the grid ``f`` and whether it is a
    resolved minimum: not at an end of the range, and the step below ``f0 / (10 Q)``.
    An unresolved minimum is only an upper bound of the true one."""
    j = int(np.argmin(curve))
    step = float(np.max(np.diff(f))) if f.size > 1 else np.inf
    return j, 0 < j < f.size - 1 and step <= f0 / (RESOLUTION * Q)
