"""A rosbags typestore that knows the sat_msgs types, built from the package's own .msg files.

rosbags (pure Python) reads and writes rosbag2 bags without ROS; it needs the message
definitions, which it parses from the same .msg sources rosidl generated the rclpy classes from.
"""

from pathlib import Path

from rosbags.typesys import get_types_from_msg, get_typestore, Stores

PACKAGE = 'sat_msgs'


def find_msg_dir() -> Path:
    """Locate sat_msgs' .msg files: the installed share/sat_msgs/msg, else the source tree."""
    try:
        from ament_index_python.packages import get_package_share_directory
        installed = Path(get_package_share_directory(PACKAGE)) / 'msg'
        if installed.is_dir():
            return installed
    except (ImportError, LookupError, ValueError):
        pass
    source = Path(__file__).resolve().parents[2] / PACKAGE / 'msg'
    if source.is_dir():
        return source
    raise FileNotFoundError(
        f'no {PACKAGE} .msg files: build the workspace (make test) or run from the source tree')


def sat_msg_types(msg_dir: Path = None) -> dict:
    """Parse every ``<Name>.msg`` into rosbags type definitions named ``sat_msgs/msg/<Name>``."""
    directory = Path(msg_dir) if msg_dir else find_msg_dir()
    types = {}
    for path in sorted(directory.glob('*.msg')):
        types.update(get_types_from_msg(path.read_text(encoding='utf-8'),
                                        f'{PACKAGE}/msg/{path.stem}'))
    if not types:
        raise FileNotFoundError(f'no .msg files in {directory}')
    return types


def sat_typestore(msg_dir: Path = None):
    """Return a ROS 2 Jazzy typestore with the sat_msgs types registered."""
    store = get_typestore(Stores.ROS2_JAZZY)
    store.register(sat_msg_types(msg_dir))
    return store
