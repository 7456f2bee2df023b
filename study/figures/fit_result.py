"""The fit figure: measurements with error bars over the fitted model (``study fit
--figure``). The model curves are evaluated from the fitted structure the file holds
(``study_fitted_structure``): thresholds in closed form, velocities by the solver."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import xarray as xr

from study.analyses.fit_model import fitted_structure, structure_groups
from study.analyses.fit_spec import PARAMETERS
from study.figures import FigureError
from study.figures.common import plt, restore_dim, save, selection_text, structure_text
from study.model import thresholds
from study.model.units import spoken
from study.solvers.exact import steady_velocity

__all__ = ["draw"]


#: A fit's variables over its measurements and over its parameters: a selection of
#: one (``--sel measurement=0``, ``parameter=cs``) keeps the dimension with length 1.
ALONG = {
    "measurement": ("quantity", "f", "a", "value", "sigma", "value_units", "direction",
                    "m_add", "M", "source", "line", "model", "residual",
                    "normalized_residual", "solver_status"),
    "parameter": ("estimate", "standard_error", "lower_bound", "upper_bound", "start",
                  "identifiable", "parameter_units", "parameter_long_name", "correlation",
                  "covariance", "profile_value", "profile_chi2"),
}


def _groups(dataset: xr.Dataset) -> list[tuple[str, float | None, float | None, np.ndarray]]:
    out = []
    for (ma, m), rows in structure_groups(dataset).items():
        label = (f"M = {m:g}" if m is not None else
                 f"m_add = {ma * 1e3:g} g" if ma is not None else "")
        out.append((label, ma, m, rows))
    return out


def _fixed_text(params: dict[str, float], free: set[str]) -> str:
    """The structure parameters the fit held fixed, with units (the shared builder)."""
    if "ck" not in params and "cs" not in free:  # ck tied to cs
        params = {**params, "ck": params.get("cs")}
    coords = {name: xr.Variable((), float(value), {
        "units": PARAMETERS[name].units if name in PARAMETERS else "m s-2"})
        for name, value in params.items() if name not in free and value is not None}
    return structure_text(xr.Dataset(coords=coords))


def draw(dataset: xr.Dataset, output: str | Path) -> list[Path]:
    """Thresholds against f and velocities against a, measured and fitted."""
    for dim, names in ALONG.items():
        dataset = restore_dim(dataset, dim, names)
    params = json.loads(dataset.attrs["study_fitted_structure"])
    coupling = str(dataset.attrs.get("study_coupling", "two-way"))
    quantity = dataset["quantity"].values.astype(str)
    f, a = dataset["f"].values, dataset["a"].values
    value, sigma = dataset["value"].values, dataset["sigma"].values
    panels = [q for q in ("threshold", "velocity") if (quantity == q).any()]
    selected = selection_text(dataset)
    if not panels and selected:
        held = ", ".join(sorted(set(quantity))) or "none"
        raise FigureError(
            "figure 'fit' draws the measured thresholds and velocities over the fitted "
            f"model, but the selection ({dataset.attrs['study_selection']}) leaves no "
            f"threshold or velocity row (measurement quantities left: {held}): select "
            "measurements of those")
    fig, axes = plt.subplots(1, max(len(panels), 1), figsize=(5.2 * max(len(panels), 1), 4.2),
                             squeeze=False)
    colours = plt.get_cmap("viridis")
    groups = _groups(dataset)
    for k, name in enumerate(panels):
        ax = axes[0, k]
        for g, (label, ma, m, rows) in enumerate(groups):
            colour = colours(g / max(len(groups) - 1, 1)) if len(groups) > 1 else "k"
            s = fitted_structure(params, 0.0 if ma is None else ma, m)
            sel = rows[quantity[rows] == name]
            if not sel.size:
                continue
            if name == "threshold":
                every = quantity == "threshold"
                lo, hi = f[every].min(), f[every].max()
                span = max(hi - lo, 0.2 * s.f0)
                grid = np.linspace(max(lo - 0.3 * span, 0.05 * s.f0), hi + 0.3 * span, 400)
                plus, minus = thresholds(s, grid)
                ax.plot(grid, np.minimum(plus, minus), color=colour, lw=1.2,
                        label=f"model {label}".strip())
                ax.errorbar(f[sel], value[sel], yerr=sigma[sel], fmt="o", ms=4,
                            color=colour, capsize=2, label=f"measured {label}".strip())
                ax.set_xlabel("drive frequency f [Hz]")
                ax.set_ylabel("motion threshold [m s$^{-2}$]")
            else:
                for fi in np.unique(f[sel]):
                    at = sel[f[sel] == fi]
                    grid = np.linspace(0.0, a[at].max() * 1.15, 60)
                    v, _ = steady_velocity(s, np.full(grid.shape, fi), grid, coupling=coupling)
                    ax.plot(grid, v * 1e3, color=colour, lw=1.0)
                    ax.errorbar(a[at], value[at] * 1e3, yerr=sigma[at] * 1e3, fmt="o", ms=4,
                                color=colour, capsize=2)
                    ax.annotate(f"{fi:g} Hz", (grid[-1], v[-1] * 1e3), fontsize=7,
                                color=colour)
                ax.set_xlabel("drive acceleration a [m s$^{-2}$]")
                ax.set_ylabel(f"steady velocity [mm s$^{{-1}}$] ({coupling})")
                ax.axhline(0.0, color="0.7", lw=0.6)
        if name == "threshold":
            ax.legend(fontsize=7)
    text = ", ".join(
        f"{p} = {e:.4g} ± {se:.2g}{spoken(str(u))}"
        for p, e, se, u in zip(dataset["parameter"].values, dataset["estimate"].values,
                               dataset["standard_error"].values,
                               dataset["parameter_units"].values, strict=True))
    chi = float(dataset["chi2_per_dof"].values)
    if "chi2_p_value" in dataset:
        chi_text = f"chi²/dof = {chi:.3g} (p = {float(dataset['chi2_p_value']):.2g})"
    else:
        chi_text = f"chi²/dof = {chi:.3g}"
    warnings = json.loads(dataset.attrs.get("study_warnings", "[]"))
    if warnings:
        chi_text += f"; {len(warnings)} warning{'s' if len(warnings) != 1 else ''} (study info)"
    fixed = _fixed_text(params, set(dataset["parameter"].values.astype(str)))
    fig.suptitle(f"fit '{dataset.attrs.get('study_fit_name')}': {text}; {chi_text}"
                 + (f"\nfixed: {fixed}" if fixed else "")
                 + (f"\n{selected}" if selected else ""), fontsize=8)
    fig.tight_layout()
    return save(fig, output, dataset, f"fit {dataset.attrs.get('study_fit_name')}")
