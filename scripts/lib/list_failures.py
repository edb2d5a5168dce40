"""Print every failed or erroring test case in a catkin test_results folder, one per line with
the first line of its message, so that a CI log names what failed (catkin_test_results gives
only per-file counts). Run with /usr/bin/python3 on a test_results folder."""
import pathlib
import sys
import xml.etree.ElementTree as ET

shown = 0
for path in sorted(pathlib.Path(sys.argv[1]).rglob("*.xml")):
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as error:
        print(f"  {path.name}: unreadable result file ({error})")
        shown += 1
        continue
    for case in root.iter("testcase"):
        for kind in ("failure", "error"):
            for problem in case.findall(kind):
                text = (problem.get("message") or problem.text or "").strip().splitlines()
                first = " | ".join(line.strip() for line in text[:3])[:240]
                name = f"{case.get('classname', '')}.{case.get('name', '')}".strip(".")
                print(f"  {kind.upper()}: {path.name}: {name}: {first}")
                shown += 1
if shown:
    print(f"  ({shown} failed test cases listed above)")
