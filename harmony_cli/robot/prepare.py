"""Make a user URDF loadable by harmony: add a virtual planar base and resolve mesh filenames.

OpTaS handles no planar/floating/continuous joints, so a mobile base must be written as two
prismatic joints (x, y) and one revolute joint (yaw) between a world root and the robot's root
link.  Mesh filenames become absolute paths so the rewritten URDF can live in a cache directory.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

from harmony_cli.robot.urdf import required

PACKAGE_SCHEME = "package://"
BASE_LIMIT = 1000.0
BASE_EFFORT = 1e4
BASE_VELOCITIES = (1.5, 1.5, 2.0)  # x, y [m/s], yaw [rad/s]
BASE_AXES = ("1 0 0", "0 1 0", "0 0 1")
BASE_TYPES = ("prismatic", "prismatic", "revolute")
LINK_PREFIXES = ("", "harmony_")  # the first one whose new link names are all free is used


def prepare_urdf(urdf: Path, base_joints: tuple[str, ...], package_paths: list[Path], cache_dir: Path) -> Path:
    """Return a URDF with the virtual base `base_joints` and absolute mesh paths.

    The original path comes back when nothing had to change; otherwise the rewritten URDF is
    written to `cache_dir` as `<stem>_<content hash>.urdf`.
    """
    original, urdf = Path(urdf), Path(urdf).resolve()
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    tree = ET.parse(urdf, parser=parser)
    robot = tree.getroot()
    added_base = _ensure_base_joints(robot, urdf, base_joints)
    resolved_meshes = _resolve_mesh_filenames(robot, urdf, [Path(p) for p in package_paths])
    if not (added_base or resolved_meshes):
        return original
    ET.indent(tree, space="  ")
    text = '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"
    return _write_cached(text, urdf.stem, Path(cache_dir))


def _ensure_base_joints(robot: ET.Element, urdf: Path, base_joints: tuple[str, ...]) -> bool:
    """Add the x/y/yaw base joints above the root link unless they all exist; True if added."""
    joint_names = {joint.get("name") for joint in robot.findall("joint")}
    present = [name for name in base_joints if name in joint_names]
    if len(present) == len(base_joints):
        return False
    if present:
        missing = [name for name in base_joints if name not in joint_names]
        raise ValueError(
            f"{urdf}: base joints {missing} are missing while {present} exist; "
            "give all three virtual base joints or none"
        )
    root_link = _root_link(robot, urdf)
    link_names = {link.get("name") for link in robot.findall("link")}
    prefix = next(
        (p for p in LINK_PREFIXES if not link_names & {f"{p}world_origin", f"{p}base_px", f"{p}base_py"}), None
    )
    if prefix is None:
        raise ValueError(f"{urdf}: cannot add a virtual base, link names world_origin/base_px/base_py are taken")
    chain = [f"{prefix}world_origin", f"{prefix}base_px", f"{prefix}base_py", root_link]
    new_elements = [_tiny_link(name) for name in chain[:3]]
    for i, name in enumerate(base_joints):
        new_elements.append(_base_joint(name, BASE_TYPES[i], chain[i], chain[i + 1], BASE_AXES[i], BASE_VELOCITIES[i]))
    robot[0:0] = new_elements  # first in file order, so first among the actuated joints
    return True


def _root_link(robot: ET.Element, urdf: Path) -> str:
    """The one link that is no joint's child."""
    children = {required(joint.find("child"), "link", "joint child") for joint in robot.findall("joint")}
    roots = [required(link, "name", "link") for link in robot.findall("link") if link.get("name") not in children]
    if len(roots) != 1:
        raise ValueError(f"{urdf}: expected one root link, found {roots}")
    return roots[0]


def _tiny_link(name: str) -> ET.Element:
    """A geometry-free, nearly massless link (1 g: simulators replace a missing inertial by 1 kg)."""
    link = ET.Element("link", name=name)
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "origin", xyz="0 0 0", rpy="0 0 0")
    ET.SubElement(inertial, "mass", value="1e-3")
    ET.SubElement(inertial, "inertia", ixx="1e-6", ixy="0", ixz="0", iyy="1e-6", iyz="0", izz="1e-6")
    return link


def _base_joint(name: str, kind: str, parent: str, child: str, axis: str, velocity: float) -> ET.Element:
    joint = ET.Element("joint", name=name, type=kind)
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=child)
    ET.SubElement(joint, "origin", xyz="0 0 0", rpy="0 0 0")
    ET.SubElement(joint, "axis", xyz=axis)
    ET.SubElement(
        joint,
        "limit",
        lower=f"{-BASE_LIMIT:g}",
        upper=f"{BASE_LIMIT:g}",
        effort=f"{BASE_EFFORT:g}",
        velocity=f"{velocity:g}",
    )
    return joint


def _resolve_mesh_filenames(robot: ET.Element, urdf: Path, package_paths: list[Path]) -> bool:
    """Rewrite package:// and relative mesh filenames as absolute paths; True if any changed."""
    changed = False
    for mesh in robot.iter("mesh"):
        filename = mesh.get("filename", "")
        if filename.startswith(PACKAGE_SCHEME):
            resolved = _resolve_package_uri(filename, urdf, package_paths)
        elif filename and "://" not in filename and not Path(filename).is_absolute():
            resolved = str((urdf.parent / filename).resolve())
        else:
            continue
        mesh.set("filename", resolved)
        changed = True
    return changed


def _resolve_package_uri(uri: str, urdf: Path, package_paths: list[Path]) -> str:
    """First existing `<search>/<pkg>/<rest>` or `<search>/<rest>` over the search paths."""
    package, _, rest = uri[len(PACKAGE_SCHEME) :].partition("/")
    tried = []
    for search in package_paths:
        for candidate in (search / package / rest, search / rest):
            tried.append(str(candidate))
            if candidate.is_file():
                return str(candidate.resolve())
    raise FileNotFoundError(f"{uri} (in {urdf}) not found; tried {tried or 'no package paths'}")


def _write_cached(text: str, stem: str, cache_dir: Path) -> Path:
    """Write `text` atomically as `<stem>_<sha256[:16]>.urdf` in `cache_dir` (kept if present)."""
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    target = cache_dir / f"{stem}_{digest}.urdf"
    if target.is_file():
        return target
    cache_dir.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(dir=cache_dir, prefix=f".{stem}_", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as handle:
            handle.write(text)
        os.replace(tmp_name, target)
    except BaseException:
        Path(tmp_name).unlink(missing_ok=True)
        raise
    return target
