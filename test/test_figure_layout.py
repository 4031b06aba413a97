"""A laid-out report figure is saved with one draw, to the same PNG."""

from __future__ import annotations

import io

from pmr_ros.report.figures import _pyplot, done_layout


def _laid_out():
    plt = _pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(4, 3))
    for k, ax in enumerate(axes):
        ax.plot([0.0, 1.0, 2.0], [1.0, k, 0.5])
        ax.set_title(f"G1{k + 1}")
    fig.tight_layout()
    return fig


def _saved(fig, *, done: bool) -> tuple[bytes, int]:
    """The PNG and how many times savefig drew the figure."""
    draws = []
    fig.canvas.mpl_connect("draw_event", lambda event: draws.append(event))
    if done:
        done_layout(fig)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=100)
    _pyplot().close(fig)
    return buffer.getvalue(), len(draws)


def test_done_layout_saves_the_same_png_with_one_draw():
    reference, reference_draws = _saved(_laid_out(), done=False)
    png, draws = _saved(_laid_out(), done=True)
    assert png == reference
    assert draws == 1 < reference_draws  # this matplotlib draws a laid-out figure twice without it
