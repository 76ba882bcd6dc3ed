"""The daylight-saving variant of ``internal_gain_schedule`` on the battery's other layouts (issue 15 p.4).

The checked battery (``bench_diagnosis_battery.py``) draws only the holiday variant; the daylight-saving
shift (occupancy on standard time all year, so it moves by an hour against the local clock at the change)
was measured on the default floor only (seeds 0-5 of 16-week data, README "Battery and speed"). These four
cases, chosen before any run (session 8), put it on the four-zone row and the nine-zone floor with a core,
at 15- and 5-minute steps, 16 weeks from 1 September (the change on 2 November), scored by the battery's
own rule (``run_case``: found with the right variant, false findings against the emulator's truth).

Run: ``python3 benchmarks/bench_dst_layouts.py [--out FILE]`` (about 10 min on the 2-core machine with the
datasets cached; results one JSON line per case).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench_diagnosis_battery import _case_line, run_case  # noqa: E402

DST = "internal_gain_schedule:kind=dst"
CASES = (
    {"id": 901, "layout": "row4", "step": 900.0, "seed": 31, "effects": [DST]},
    {"id": 902, "layout": "core9", "step": 900.0, "seed": 32, "effects": [DST]},
    {"id": 903, "layout": "row4", "step": 300.0, "seed": 33, "effects": [DST]},
    {"id": 904, "layout": "core9", "step": 300.0, "seed": 34, "effects": [DST]},
)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="dst-layouts.jsonl", help="JSON-lines file of the results")
    ap.add_argument("--weeks", type=int, default=16)
    args = ap.parse_args(argv)
    found = 0
    with open(args.out, "a") as f:
        for case in CASES:
            r = run_case(dict(case), args.weeks)
            f.write(json.dumps(r) + "\n")
            f.flush()
            found += bool(r["found"])
            print(_case_line(r), flush=True)
    print(f"daylight-saving shift found in {found} of {len(CASES)} cases")


if __name__ == "__main__":
    main()
