"""Pages that read (issue #49, item 5): no two texts of a figure overlap.

:func:`drawn_texts` draws a :class:`matplotlib.figure.Figure` and returns every visible, non-empty
:class:`matplotlib.text.Text` it holds (``fig.findobj``: titles, axis labels, tick labels, annotations,
legend texts, colour-bar labels, captions) that the draw actually put on the canvas, each with its
window extent in pixels; :func:`overlaps` lists the pairs of them whose extents overlap by more than a
pixel each way, and :func:`assert_no_overlap` fails naming them.

"Drawn" matters for tick labels: matplotlib keeps Tick objects (and their labels, visible, with stale
texts) for ticks outside the view limits and skips them when it draws; an annotation whose point lies
outside its axes is skipped too. A text drawn in a box (``bbox=``, the numbered landmarks of a render)
occupies its box: the extent is the union of the text's and the box's (an annotation's leader line is
not text and not counted).

Extents are axis-aligned: a text rotated by 90 degrees is measured exactly, one rotated by another angle
by its bounding box (the figures of vesselgp rotate none by other angles).
"""
from __future__ import annotations

import contextlib

from matplotlib.text import Text
from matplotlib.transforms import Bbox

#: Overlap (pixels) tolerated each way between two texts' extents: the rounding of a glyph's box.
SLACK_PX = 1.0


@contextlib.contextmanager
def _recording_draws():
    """While active, every :class:`Text` whose ``draw`` runs is recorded (its id) in the yielded set."""
    drawn = set()
    real = Text.draw

    def draw(self, renderer):
        drawn.add(id(self))
        return real(self, renderer)

    Text.draw = draw
    try:
        yield drawn
    finally:
        Text.draw = real


def _extent(t, renderer):
    """The display box of ``t``'s text and the box drawn round it (an annotation's arrow, a leader line to its
    point, is not text: :meth:`matplotlib.text.Annotation.get_window_extent` would include it)."""
    e = Text.get_window_extent(t, renderer)
    patch = t.get_bbox_patch()
    if patch is not None and patch.get_visible():
        e = Bbox.union([e, patch.get_window_extent(renderer)])
    return e


def drawn_texts(fig):
    """``[(text, extent)]``: the visible, non-empty texts of ``fig`` that a draw puts on the canvas.

    Parameters
    ----------
    fig : matplotlib.figure.Figure

    Returns
    -------
    list of (matplotlib.text.Text, matplotlib.transforms.Bbox)
        Extents in display pixels (at the figure's dpi).
    """
    with _recording_draws() as drawn:
        fig.canvas.draw()
    r = fig.canvas.get_renderer()
    out = []
    for t in fig.findobj(Text):
        if id(t) in drawn and t.get_visible() and t.get_text().strip():
            out.append((t, _extent(t, r)))
    return out


def overlaps(fig, slack=SLACK_PX):
    """Pairs of drawn texts of ``fig`` whose extents overlap by more than ``slack`` pixels both ways.

    Returns
    -------
    list of (str, str, float, float)
        The two texts and the overlap's width and height in pixels.
    """
    items = drawn_texts(fig)
    found = []
    for i, (a, ea) in enumerate(items):
        for b, eb in items[i + 1:]:
            w = min(ea.x1, eb.x1) - max(ea.x0, eb.x0)
            h = min(ea.y1, eb.y1) - max(ea.y0, eb.y0)
            if w > slack and h > slack:
                found.append((a.get_text(), b.get_text(), round(w, 1), round(h, 1)))
    return found


def assert_no_overlap(fig, name="figure", slack=SLACK_PX):
    """Fail, naming the texts, when two drawn texts of ``fig`` overlap (:func:`overlaps`)."""
    found = overlaps(fig, slack)
    assert not found, f"{name}: {len(found)} overlapping text pair(s): " + "; ".join(
        f"{a!r} / {b!r} ({w} x {h} px)" for a, b, w, h in found[:12])
