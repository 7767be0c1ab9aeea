"""Print one pytest-style summary line of JUnit XML reports, with a label.

    python3 .ci/junit_summary.py REPORT.xml [REPORT.xml ...] LABEL

prints ``N passed (LABEL)`` or ``F failed, N passed (LABEL)`` (errors count as failures,
skips are named), the form ``.ci/test`` adds up.
"""

import sys
import xml.etree.ElementTree as ET


def main(paths, label):
    passed = failed = skipped = 0
    for path in paths:
        for suite in ET.parse(path).getroot().iter("testsuite"):
            fail = int(suite.get("failures")) + int(suite.get("errors"))
            skip = int(suite.get("skipped"))
            passed += int(suite.get("tests")) - fail - skip
            failed += fail
            skipped += skip
    counts = f"{failed} failed, {passed} passed" if failed else f"{passed} passed"
    print(f"{counts} ({label}{f', {skipped} skipped' if skipped else ''})")


if __name__ == "__main__":
    main(sys.argv[1:-1], sys.argv[-1])
