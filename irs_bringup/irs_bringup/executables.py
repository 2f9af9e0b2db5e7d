"""Resolve node executables exactly as ``ros2 run <package> <executable>`` does.

``ros2 run`` (ros2run/ros2pkg) asks the ament index for the package's install prefix
(``share/ament_index/resource_index/packages/<package>`` under one of the prefixes in
``AMENT_PREFIX_PATH``) and then runs ``<prefix>/lib/<package>/<executable>``. We do the same, so
whatever our bringup starts is what ``ros2 run`` would start.

Run as a module to print the path:
``python -m irs_bringup.executables <package> <executable>``.
"""
import os
import sys

from ament_index_python.packages import PackageNotFoundError, get_package_prefix


class ExecutableNotFound(LookupError):
    """The package or its executable is not in the ament index."""


def package_executables(package: str) -> list[str]:
    """Names of the executables installed in ``<prefix>/lib/<package>``, sorted."""
    try:
        prefix = get_package_prefix(package)
    except PackageNotFoundError as exc:
        raise ExecutableNotFound(
            f"package '{package}' is not in the ament index "
            f'(AMENT_PREFIX_PATH={os.environ.get("AMENT_PREFIX_PATH", "")!r})'
        ) from exc
    lib_dir = os.path.join(prefix, 'lib', package)
    if not os.path.isdir(lib_dir):
        return []
    return sorted(name for name in os.listdir(lib_dir)
                  if os.path.isfile(os.path.join(lib_dir, name))
                  and os.access(os.path.join(lib_dir, name), os.X_OK))


def resolve_executable(package: str, executable: str) -> str:
    """Absolute path of ``executable`` of ``package``, as ``ros2 run`` would find it."""
    names = package_executables(package)
    if executable not in names:
        raise ExecutableNotFound(f"no executable '{executable}' in package '{package}'; "
                                 f"it has: {', '.join(names) or 'none'}")
    return os.path.join(get_package_prefix(package), 'lib', package, executable)


def main(argv=None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2:
        print(
            'usage: python -m irs_bringup.executables <package> <executable>', file=sys.stderr
        )
        return 2
    try:
        print(resolve_executable(*args))
    except ExecutableNotFound as exc:
        print(f'irs: {exc}', file=sys.stderr)
        return 1
    return 0


if __name__ == '__main__':
    sys.exit(main())
