"""harmony's version is written once (harmony_cli.__version__): the installed package's metadata and `harmony
--version` say the same, and the CHANGELOG has its section."""

import re
import subprocess
import sys
from importlib.metadata import version

from conftest import ROOT

import harmony_cli


def test_the_installed_metadata_and_harmony_version_give_the_version_the_package_holds():
    printed = subprocess.run(
        [sys.executable, "-c", "from harmony_cli.cli import main; main()", "--version"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    assert printed == f"harmony {harmony_cli.__version__}"
    assert version("harmony-cli") == harmony_cli.__version__


def test_the_changelog_has_a_dated_section_for_the_version_the_package_holds():
    changelog = (ROOT / "CHANGELOG.md").read_text()
    heading = re.compile(rf"^## \[{re.escape(harmony_cli.__version__)}\] - \d{{4}}-\d{{2}}-\d{{2}}$", re.MULTILINE)
    assert heading.search(changelog), f"CHANGELOG.md has no '## [{harmony_cli.__version__}] - YYYY-MM-DD' section"
