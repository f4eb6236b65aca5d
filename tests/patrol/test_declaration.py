"""What every node process of the patrol imports (``python -m patrol node``: the framework's
command and the patrol's declaration) must not pull in matplotlib, which only the reports draw
with and which takes a good part of a second to import."""

from __future__ import annotations

import subprocess
import sys

CHECK = """
import sys
import application.cli
import patrol.declaration
print(sorted(name for name in sys.modules if name.startswith("matplotlib")))
"""


def test_a_node_process_imports_no_plotting():
    done = subprocess.run([sys.executable, "-c", CHECK], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"
