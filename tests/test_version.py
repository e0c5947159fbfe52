"""harmony's version is written once (harmony_cli.__version__): the installed package's metadata and `harmony
--version` say the same."""

import subprocess
import sys
from importlib.metadata import version

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
