"""Open a report in headless Chromium (Debian's ``chromium``) and measure what a reader sees."""
from __future__ import annotations

import json
import shutil
import subprocess
import tempfile
from pathlib import Path

#: Runs in the page once it has loaded: horizontal overflow of the page (px) and the score-table
#: cells that show nothing.
PROBE = """<script>
window.addEventListener('load', () => {
  const de = document.documentElement;
  const cells = Array.from(document.querySelectorAll('table.scores td'));
  const empty = cells.filter(td => td.textContent.trim() === '' || td.textContent.trim() === 'nan').length;
  document.body.setAttribute('data-check', JSON.stringify(
    {overflow: de.scrollWidth - de.clientWidth, width: de.clientWidth, cells: cells.length, empty: empty}));
});
</script>"""

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def chromium() -> str:
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    raise RuntimeError("Chromium is not installed: scripts/install.sh installs Debian's chromium for the tests")


def check_report(report: Path, width: int = 1400) -> dict:
    """Load ``report`` at ``width`` px and return the probe's measurements."""
    with tempfile.TemporaryDirectory() as tmp:
        page = Path(tmp) / "report.html"
        page.write_text(report.read_text().replace("</body>", PROBE + "</body>"))
        cmd = [chromium(), *FLAGS, f"--user-data-dir={tmp}/profile", f"--window-size={width},1000",
               "--virtual-time-budget=5000", "--dump-dom", page.as_uri()]
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=180, check=True).stdout
    marker = "data-check=\""
    start = out.index(marker) + len(marker)
    return json.loads(out[start:out.index('"', start)].replace("&quot;", '"'))


def screenshot(report: Path, png: Path, width: int = 1400, height: int = 4000) -> Path:
    """A PNG of the top of the report as Chromium renders it."""
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([chromium(), *FLAGS, f"--user-data-dir={tmp}/profile", f"--window-size={width},{height}",
                        f"--screenshot={png}", report.resolve().as_uri()], capture_output=True, timeout=180, check=True)
    return png
