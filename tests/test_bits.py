"""Same physics, same bits: `simulate`'s spectra, impulses and leaf counts on the cases of
`_bits_cases.py` hash to the values recorded on the engine of the paper (main at d189db4).
Any change to the core that moves a bit of these results fails here; a change that means to
move them must say so and record the new values."""

from __future__ import annotations

import pytest
from _bits_cases import cases, digest

RECORDED = {
    "box1000-cone-paper-exact-None": "13096ab8d4e67f93c331609d",
    "box1000-cone-paper-fast-0.001": "ccf1970635085e54a2573cdf",
    "box1000-cone-paper-fast-1e-06": "da3d2066381722e93cc472c3",
    "box1000-cone-paper-fast-1e-12": "7df3b4d32417876abcdae8cc",
    "box1000-cone-po-exact-None": "f517a74f817a4d3dbb7959d5",
    "box1000-cone-po-fast-0.001": "e1fde905f7afb58af9a2a02f",
    "box1000-cone-po-fast-1e-06": "e9bea9ba65d904de6e940ba3",
    "box1000-cone-po-fast-1e-12": "cbd4b28702bc0e1a006726b3",
    "box1000-cone-absorb-exact-None": "282b9ff152999435e7ccb859",
    "box1000-cone-absorb-fast-0.001": "0f6b61063bd5030c6979c569",
    "box1000-cone-absorb-fast-1e-06": "c54e428045695137cab9b2b8",
    "box1000-cone-absorb-fast-1e-12": "6f0b62a8434da45869061e51",
    "box20000-cone-paper-exact-None": "fe5ed80aedc85c8ff8ff8346",
    "box20000-cone-paper-fast-0.001": "fac4f4390059477a4e9a25c6",
    "box20000-cone-paper-fast-1e-06": "5e329efe13c71713475fc246",
    "box20000-cone-paper-fast-1e-12": "49a6142eb34867e6215d7f4c",
    "box20000-cone-po-exact-None": "79bae5df5e767ed9a939a862",
    "box20000-cone-po-fast-0.001": "2a7c27b62932e10748f4af1f",
    "box20000-cone-po-fast-1e-06": "1403f49232b3b67d4697a0a7",
    "box20000-cone-po-fast-1e-12": "e458183151d090e8fbc77b58",
    "box20000-cone-absorb-exact-None": "a2c9b3b1e584817882c97a19",
    "box20000-cone-absorb-fast-0.001": "9bc3883ce1c506c44df4e6b0",
    "box20000-cone-absorb-fast-1e-06": "42a5a0fe39fecdaefe69a806",
    "box20000-cone-absorb-fast-1e-12": "9285d426ccbcc97c603a38b3",
    "forest-detectable-exact-None": "8fec41209257a534d6d2e148",
    "forest-detectable-fast-0.001": "e2cf173ecb3526e0e5331c4d",
    "forest-detectable-fast-1e-06": "c8567b2c8079831a737b2402",
    "forest-detectable-fast-1e-12": "9455b3b20f3a9887893e1a2a",
    "forest-detectable-po-absorb-exact-None": "57ad81b3aedf23fd1261689c",
    "forest-detectable-po-absorb-fast-0.001": "63451b219a81cd27019995af",
    "forest-detectable-po-absorb-fast-1e-06": "01f0d1c161acdc5f75b7269c",
    "forest-detectable-po-absorb-fast-1e-12": "6763ff93726572cd36b389e3",
}


@pytest.mark.parametrize(
    ("name", "key", "sonar", "method", "tol"),
    cases(),
    ids=lambda v: v if isinstance(v, str) else None,
)
def test_simulate_keeps_its_recorded_bits(name, key, sonar, method, tol):
    assert digest(key, sonar, method, tol) == RECORDED[name]


def test_every_case_has_a_recorded_checksum():
    assert sorted(n for n, *_ in cases()) == sorted(RECORDED)
