"""
Prefix a URDF's link names with the robot name, as the Interbotix descriptions do.

Interbotix URDFs name links ``<robot_name>/<link>`` (``px100/base_link``) so that several arms
share one tf tree, while joint names stay bare (``waist``), as joint_states carries them. The
files in ``urdf/`` have bare link names; :func:`prefix_urdf` rewrites ``<link name>`` and every
``<parent link>``/``<child link>`` reference (plus Gazebo ``reference`` attributes naming a link).
Pure text processing (xml.etree), no ROS.
"""
from typing import Optional
import xml.etree.ElementTree as ET

from px100_control.errors import RobotModelError


def prefix_frame(prefix: Optional[str], frame: str) -> str:
    """
    Return ``<prefix>/<frame>`` (``frame`` unchanged for an empty prefix or if already prefixed).

    Example Input: prefix='px100', frame='base_link'  Output: 'px100/base_link'
    """
    prefix = (prefix or '').strip('/')
    if not prefix or frame.startswith(prefix + '/'):
        return frame
    return f'{prefix}/{frame}'


def prefix_urdf(urdf_xml: str, prefix: Optional[str]) -> str:
    """
    Return the URDF text with every link name (and link reference) prefixed ``<prefix>/``.

    Joint names are kept. Applying it twice gives the same result as once.
    :raises RobotModelError: the text is not XML with a <robot> root
    """
    try:
        root = ET.fromstring(urdf_xml)
    except ET.ParseError as exc:
        raise RobotModelError(f'URDF is not valid XML: {exc}') from exc
    if root.tag != 'robot':
        raise RobotModelError(f'URDF root element is <{root.tag}>, not <robot>')
    if not (prefix or '').strip('/'):
        return urdf_xml
    links = {el.get('name') for el in root.findall('link')}
    for el in root.findall('link'):
        el.set('name', prefix_frame(prefix, el.get('name')))
    for joint in root.findall('joint'):
        for tag in ('parent', 'child'):
            ref = joint.find(tag)
            if ref is not None and ref.get('link') is not None:
                ref.set('link', prefix_frame(prefix, ref.get('link')))
    for el in root.iter('gazebo'):
        ref = el.get('reference')
        if ref in links:
            el.set('reference', prefix_frame(prefix, ref))
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding='unicode')
