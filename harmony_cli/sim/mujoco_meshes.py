"""The prepared URDF's text as MuJoCo's URDF compiler can take it: visuals dropped (MuJoCo would still load their
meshes) and collision meshes in a format MuJoCo cannot read (.dae) converted once with trimesh to binary STL,
cached under harmony's cache dir by the source file's content hash (a changed file is converted again).

Mesh paths are already absolute in the prepared URDF (package:// resolved by robot/prepare.py). trimesh flattens a
COLLADA scene with its node transforms applied; MuJoCo then takes the mesh in the link frame, scaled by the URDF's
scale attribute, as PyBullet does.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

from harmony_cli.cache import CACHE_DIR

READABLE = (".stl", ".obj", ".msh")  # mesh formats MuJoCo reads itself
MESH_CACHE = CACHE_DIR / "mujoco_meshes"


def mujoco_urdf(urdf: Path, compiler: str) -> str:
    """`urdf`'s text for MuJoCo: `compiler` (a <mujoco> element) first in the robot, no visuals, readable meshes."""
    robot = ET.parse(urdf).getroot()
    for link in robot.findall("link"):
        for visual in link.findall("visual"):
            link.remove(visual)
    for mesh in robot.iter("mesh"):
        filename = mesh.get("filename", "")
        if Path(filename).suffix.lower() not in READABLE:
            mesh.set("filename", str(readable_mesh(Path(filename))))
    robot.insert(0, ET.fromstring(compiler))
    return ET.tostring(robot, encoding="unicode")


def readable_mesh(path: Path) -> Path:
    """A binary STL of the mesh at `path`, converted with trimesh on first use and kept in MESH_CACHE."""
    digest = hashlib.sha256(path.read_bytes()).hexdigest()[:16]
    target = MESH_CACHE / f"{path.stem}_{digest}.stl"
    if target.is_file():
        return target
    import trimesh  # only robots with such meshes need it

    mesh = trimesh.load(path, force="mesh")
    MESH_CACHE.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=MESH_CACHE, suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as out:
            out.write(mesh.export(file_obj=None, file_type="stl"))
        os.replace(tmp, target)  # atomic: a concurrent run reads no half-written mesh
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return target
