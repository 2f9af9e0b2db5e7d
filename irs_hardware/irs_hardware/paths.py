"""``pkg://<package>/<path>`` references to installed files (ament index), or plain paths."""
from pathlib import Path


def resolve(ref: str) -> Path:
    """The file a reference names; ``pkg://irs_hardware/config/x.yaml`` -> share/... ."""
    if ref.startswith('pkg://'):
        from ament_index_python.packages import get_package_share_directory
        package, _, rest = ref[len('pkg://'):].partition('/')
        try:
            return Path(get_package_share_directory(package)) / rest
        except LookupError:
            raise ValueError(f'{ref}: no installed package {package!r}') from None
    return Path(ref)
