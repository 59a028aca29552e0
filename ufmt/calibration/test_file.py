"""Any modal-test file to a :class:`~ufmt.calibration.modal_test.ModalTest`: measured FRFs (a
universal file with dataset 58 or a CSV FRF table, :mod:`.frf_file`) through the modal
extraction of :mod:`.frf_modes`; a modal-test CSV or a universal file of modes as
:func:`~ufmt.calibration.modal_test.read_modal_test` reads it."""

from __future__ import annotations

from ufmt.calibration.frf_file import is_frf_file
from ufmt.calibration.frf_modes import extract_modes
from ufmt.calibration.modal_test import ModalTest, read_modal_test


def read_test(path, unit: str | None = None, **extraction) -> ModalTest:
    """The modal test in ``path``; measured FRFs are reduced to modes with ``extraction``
    (the keywords of :func:`~ufmt.calibration.frf_modes.extract_modes`) and ``unit`` (their
    node positions' unit when the file does not say)."""
    if is_frf_file(path):
        return extract_modes(path, unit=unit, **extraction).test
    return read_modal_test(path, unit)
