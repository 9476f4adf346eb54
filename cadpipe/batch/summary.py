"""The batch's report: ``summary.json`` and ``summary.html``, one row per job.

Both are written atomically at the end of a batch (also when it is interrupted), from
the records the jobs returned. A job whose folder holds a ``job.json`` with the same
content hash, status "ok" and every listed file at its recorded size is complete:
:func:`completed` gives its record back so a re-run skips it.
"""

import html
import json
from datetime import UTC, datetime
from pathlib import Path as FilePath

from cadpipe.batch.work import RECORD, write_json
from cadpipe.io.files import atomic_path

SUMMARY_JSON, SUMMARY_HTML = "summary.json", "summary.html"
#: statuses a summary row can have, in the order the counts list them
STATUSES = ("ok", "failed", "not run")


def completed(job, out):
    """The record of ``job`` left in ``out`` by an earlier run if its outputs are complete
    and its content hash matches, else None."""
    folder = FilePath(out) / job.name
    try:
        record = json.loads((folder / RECORD).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict) or record.get("hash") != job.hash or \
            record.get("status") != "ok" or not isinstance(record.get("files"), dict):
        return None
    for name, size in record["files"].items():
        path = folder / name
        if not path.is_file() or path.stat().st_size != size:
            return None
    return record


def counts(records):
    """How many rows have each status, and how many were reused from an earlier run."""
    found = {status: sum(r["status"] == status for r in records) for status in STATUSES}
    found["reused"] = sum(bool((r.get("run") or {}).get("reused")) for r in records)
    return found


def write(out, records, *, engine, interrupted, started):
    """Write ``summary.json`` and ``summary.html`` into ``out``; returns their paths."""
    out = FilePath(out)
    from cadpipe import __version__

    summary = {"cadpipe": __version__, "engine": engine, "interrupted": interrupted,
               "started": started, "finished": now(), "counts": counts(records),
               "jobs": records}
    paths = [write_json(out / SUMMARY_JSON, summary), out / SUMMARY_HTML]
    with atomic_path(paths[1]) as tmp:
        tmp.write_text(page(summary), encoding="utf-8")
    return paths


def now():
    return datetime.now(UTC).isoformat(timespec="seconds")


def _moment(m):
    if m is None:
        return ""
    at = f"t = {m['time']:.3f} s" if m.get("time") is not None else ""
    return f"{at} (waypoint {m['waypoint']:g})" if at else f"waypoint {m['waypoint']:g}"


def _cells(r):
    """The HTML cells of one row."""
    e = html.escape
    first = r["first_collision"]
    hit = "" if first is None else \
        "<br>".join(e(f"{a} \u2194 {b}") for a, b in first["pairs"]) + \
        f"<br><small>{e(_moment(first))}</small>"
    gap = r["clearance"]
    clear = "" if gap is None else \
        f"{gap['distance'] * 1000:.1f} mm<br><small>{e(gap['a'])} \u2194 {e(gap['b'])}, " \
        f"{e(_moment(gap))}</small>"
    if r["solid"] is not None:
        s = r["solid"]
        clear = f"{s['triangles']:,} triangles, volume {s['volume']:.6g} {e(s['units'])}\u00b3" \
            f", watertight={s['watertight']}"
    files = ", ".join(f'<a href="{e(r["name"])}/{e(name)}">{e(name)}</a>'
                      for name in r["files"])
    params = ", ".join(f"{e(k)}={e(json.dumps(v))}" for k, v in r["params"].items())
    run = r.get("run") or {}
    seconds = "" if not run else ("reused" if run.get("reused") else f"{run['seconds']:.2f} s")
    return [e(r["name"]), e(r["kind"]), params, e(r["status"]), e(r["verdict"] or ""), hit,
            clear, files, e(r["error"] or ""), seconds]


HEADER = ("job", "kind", "parameters", "status", "verdict", "first collision",
          "clearance / solid", "files", "error", "time")
STYLE = """body{font:14px system-ui,sans-serif;margin:2em;color:#111}
table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:4px 8px;text-align:left;
vertical-align:top}th{background:#f3f4f6}tr.failed td{background:#fee2e2}
tr.collision td{background:#fef3c7}tr.not-run td{color:#6b7280}small{color:#4b5563}"""


def page(summary):
    """The self-contained HTML page of a summary."""
    c = summary["counts"]
    head = "".join(f"<th>{h}</th>" for h in HEADER)
    rows = []
    for r in summary["jobs"]:
        kind = "failed" if r["status"] == "failed" else "not-run" if r["status"] == "not run" \
            else "collision" if r["verdict"] in ("collision", "too close") else ""
        cells = "".join(f"<td>{cell}</td>" for cell in _cells(r))
        rows.append(f'<tr class="{kind}">{cells}</tr>')
    state = " (interrupted: the jobs not run are listed as such)" if summary["interrupted"] \
        else ""
    return (f"<!doctype html><html><head><meta charset=\"utf-8\"><title>cadpipe batch</title>"
            f"<style>{STYLE}</style></head><body><h1>cadpipe batch{state}</h1>"
            f"<p>{c['ok']} ok ({c['reused']} reused from an earlier run), {c['failed']} failed, "
            f"{c['not run']} not run; engine {html.escape(summary['engine'])}; "
            f"cadpipe {html.escape(summary['cadpipe'])}; started {summary['started']}, "
            f"finished {summary['finished']}.</p>"
            f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"
            f"</body></html>\n")
