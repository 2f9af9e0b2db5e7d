"""ROS domain ids for test and benchmark runs: one per run, never shared by two at once.

A run claims the first free id of its range, starting from its pid's place in it, and holds an
exclusive ``flock`` on ``<lock_dir>/irs_test_domain_<id>.lock`` for as long as its process lives
(the lock goes with the process, also a killed one), so concurrent runs on one machine never see
each other's topics. The range is every id Fast DDS can use on one machine (its port arithmetic
allows 0-101 and 215-232; 0 is left out: it is every shell's default, a hand-started graph's),
or the ids ``IRS_TEST_DOMAINS`` names (``81-89`` or ``81,83,90-95``), to keep the suite to its
share of a shared machine.

A run on a domain of its own choosing (``IRS_TEST_DOMAIN_FIXED``) holds a shared ``flock`` on
the same file (:func:`hold_domain`): runs that claim ids pass it by, and several runs that chose
the same id may share it, as they asked.
"""
import fcntl
import os

#: Every domain id the suite may use unless ``IRS_TEST_DOMAINS`` narrows it.
VALID_DOMAINS = tuple(range(1, 102)) + tuple(range(215, 233))


class DomainError(RuntimeError):
    """No domain id can be claimed (a bad ``IRS_TEST_DOMAINS`` or every id held)."""


def parse_domains(text: str) -> tuple:
    """``'81-89'`` / ``'81,83,90-95'`` -> the ids, each checked against :data:`VALID_DOMAINS`."""
    ids = []
    for part in text.replace(' ', '').split(','):
        lo, sep, hi = part.partition('-')
        try:
            first, last = int(lo), int(hi if sep else lo)
        except ValueError:
            raise DomainError(f"IRS_TEST_DOMAINS={text!r}: expected ids or ranges like "
                              f"'81-89' or '81,83,90-95', got {part!r}") from None
        if first > last:
            raise DomainError(f'IRS_TEST_DOMAINS={text!r}: range {part!r} runs backwards')
        ids += range(first, last + 1)
    bad = sorted(set(ids) - set(VALID_DOMAINS))
    if bad:
        raise DomainError(f'IRS_TEST_DOMAINS={text!r}: {bad} are not usable ROS domain ids '
                          '(1-101 or 215-232)')
    return tuple(dict.fromkeys(ids))


def domain_range(environ=os.environ) -> tuple:
    """The ids this run may use: ``IRS_TEST_DOMAINS`` if set, else :data:`VALID_DOMAINS`."""
    text = environ.get('IRS_TEST_DOMAINS', '').strip()
    return parse_domains(text) if text else VALID_DOMAINS


def claim_domain(pid: int, domains=None, lock_dir: str = '/tmp') -> tuple:
    """``(domain id, open lock file)``: the first free id from ``pid``'s place in ``domains``
    (default :func:`domain_range`) on; :class:`DomainError` if every one is held.
    """
    domains = domain_range() if domains is None else tuple(domains)
    n = len(domains)
    for i in range(n):
        domain = domains[(pid + i) % n]
        f = open(os.path.join(lock_dir, f'irs_test_domain_{domain}.lock'), 'a')
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            f.close()
            continue
        return domain, f
    raise DomainError(f'all {n} ROS domain ids {domains[0]}..{domains[-1]} are held by other '
                      f'runs ({lock_dir}/irs_test_domain_*.lock)')


def hold_domain(domain: int, lock_dir: str = '/tmp') -> tuple:
    """``(open lock file, None)`` with a shared ``flock`` on ``domain``'s lock file, which keeps
    :func:`claim_domain` of other runs off it; ``(None, warning)`` when a run that claimed it
    holds it (its topics and this run's would mix).
    """
    path = os.path.join(lock_dir, f'irs_test_domain_{domain}.lock')
    f = open(path, 'a')
    try:
        fcntl.flock(f, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except OSError:
        f.close()
        return None, (f'ROS_DOMAIN_ID {domain} is held by another test or benchmark run '
                      f"({path}): its topics and this run's will mix")
    return f, None
