"""Make catkin_test_results count each gtest test once.

gtest >= 1.10 writes totals on the root <testsuites> element as well as on each <testsuite>;
Debian's catkin 0.8.10 adds both, so every test would be counted twice. This removes the totals
from the root element of each gtest result file (the per-suite counts and every <testcase> are
left as they are). Run with /usr/bin/python3 on a test_results folder.
"""
import pathlib
import sys
import xml.etree.ElementTree as ET

for path in pathlib.Path(sys.argv[1]).rglob("gtest-*.xml"):
    tree = ET.parse(path)
    root = tree.getroot()
    if root.tag == "testsuites" and any(child.tag == "testsuite" for child in root):
        for key in ("tests", "failures", "errors", "disabled", "skipped"):
            root.attrib.pop(key, None)
        tree.write(path, encoding="UTF-8", xml_declaration=True)
