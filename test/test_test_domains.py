"""The suite's ROS domains come from the environment (issue 29): ``JOINTWEAR_TEST_DOMAINS=LO-HI``, split
between pytest-xdist workers, and ``make test`` takes a block no other running suite holds."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from conftest import DEFAULT_DOMAINS, DOMAINS_ENV, domains_of_this_process, free_domain_block, parse_domains


def test_a_range_is_lo_to_hi_inclusive():
    assert parse_domains("10-149") == range(10, 150)
    assert parse_domains(" 40-40 ") == range(40, 41)
    assert parse_domains("7") == range(7, 8)
    assert parse_domains(DEFAULT_DOMAINS) == range(10, 150)


@pytest.mark.parametrize("bad", ["", "a-b", "10-", "50-20", "200-240", "-5-10", "1-2-3"])
def test_a_bad_range_is_refused_naming_the_variable(bad):
    with pytest.raises(ValueError, match=DOMAINS_ENV):
        parse_domains(bad)


def test_xdist_workers_of_a_run_take_disjoint_shares_of_its_range():
    gw0 = domains_of_this_process("40-59", "gw0", "2")
    gw1 = domains_of_this_process("40-59", "gw1", "2")
    assert set(gw0).isdisjoint(gw1) and set(gw0) | set(gw1) == set(range(40, 60))
    assert domains_of_this_process("40-59", None, None) == range(40, 60)


def test_the_modules_domain_is_in_the_runs_range():
    assert int(os.environ["ROS_DOMAIN_ID"]) in parse_domains(os.environ.get(DOMAINS_ENV, DEFAULT_DOMAINS))


@pytest.mark.skipif(not os.path.isdir("/proc"), reason="reads other processes' environment from /proc")
def test_a_free_block_overlaps_no_running_suites_range():
    holders = []
    try:
        for held in ("10-29", "30-49"):
            holders.append(subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"],
                                            env=dict(os.environ, **{DOMAINS_ENV: held})))
        # the children's environment is readable once they run: wait for it, not for a time
        for p, held in zip(holders, ("10-29", "30-49")):
            while f"{DOMAINS_ENV}={held}".encode() not in open(f"/proc/{p.pid}/environ", "rb").read():
                pass
        block = parse_domains(free_domain_block(width=20, first=10, last=229))
        assert len(block) == 20 and block[0] >= 50 and block[-1] <= 229
    finally:
        for p in holders:
            p.kill()
            p.wait()
