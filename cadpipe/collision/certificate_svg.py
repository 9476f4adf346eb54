"""SVG drawings of separation certificates: R, both projected objects, the chain."""

from xml.sax.saxutils import escape

import numpy as np

AXIS_NAMES = "xyz"
COLOURS = ("#1f77b4", "#ff7f0e")


def render(cert, size=480):
    """The certificate as an SVG document string, ``size`` pixels on its long side."""
    boxes = np.asarray(cert.boxes)
    lo = np.minimum(boxes[:, 0].min(axis=0), cert.rectangle[0])
    hi = np.maximum(boxes[:, 1].max(axis=0), cert.rectangle[1])
    span = float(np.max(hi - lo)) or 1.0
    pad = 0.05 * span
    scale = size / (span + 2 * pad)
    width, height = ((hi - lo) + 2 * pad) * scale

    def xy(points):
        points = np.atleast_2d(points)
        x = (points[:, 0] - lo[0] + pad) * scale
        y = height - (points[:, 1] - lo[1] + pad) * scale      # SVG's y grows downward
        return " ".join(f"{a:.2f},{b:.2f}" for a, b in zip(x, y))

    def rect(box, style):
        corners = np.array([box[0], [box[1][0], box[0][1]], box[1], [box[0][0], box[1][1]]])
        return f'<polygon points="{xy(corners)}" {style}/>'

    u, v = (AXIS_NAMES[a] for a in cert.axes)
    title = (f"{cert.names[0]} vs {cert.names[1]}: {cert.kind} certificate in the "
             f"{u}{v} plane")
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" '
             f'height="{height + 24:.0f}" viewBox="0 -24 {width:.2f} {height + 24:.2f}">',
             f'<title>{escape(title)}</title>',
             f'<text x="4" y="-8" font-family="sans-serif" font-size="12">{escape(title)}</text>']
    for box, colour in zip(boxes, COLOURS):
        parts.append(rect(box, f'fill="none" stroke="{colour}" stroke-dasharray="4 3"'))
    if cert.kind != "boxes":
        parts.append(rect(cert.rectangle, 'fill="#f4f4f4" stroke="#555"'))
    for rings, colour, name in zip(cert.regions, COLOURS, cert.names):
        if rings:
            path = " ".join(f"M {xy(r)} Z" for r in rings)
            parts.append(f'<path d="{path}" fill="{colour}" fill-opacity="0.45" '
                         f'fill-rule="evenodd" stroke="{colour}"><title>{escape(name)}</title>'
                         '</path>')
    if len(cert.chain):
        parts.append(f'<polyline points="{xy(cert.chain)}" fill="none" stroke="#d62728" '
                     'stroke-width="2"/>')
        for p in (cert.chain[0], cert.chain[-1]):
            x, y = xy(p).split(",")
            parts.append(f'<circle cx="{x}" cy="{y}" r="4" fill="#d62728"/>')
    parts.append("</svg>")
    return "\n".join(parts) + "\n"
