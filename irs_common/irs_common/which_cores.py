"""Print which cores this workspace's processes run: ``python -m irs_common.which_cores``.

One line: ``compiled``, or ``interpreted: <why>`` (:data:`irs_common.native_cores.status`, set by
the venv's ``irs_native_cores.pth`` at the interpreter's start).
"""
from irs_common import native_cores


def main() -> None:
    print(native_cores.status or 'interpreted: no finder was installed at start (the venv has no '
                                 'irs_native_cores.pth: `make build` writes it)')


if __name__ == '__main__':
    main()
