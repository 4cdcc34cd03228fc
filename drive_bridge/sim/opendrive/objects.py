"""Object indices, codes and fixed values of the OPEN drive (opendrive.md §2, §3)."""
from __future__ import annotations

STORE_PARAMETERS, RESTORE_PARAMETERS = 0x1010, 0x1011
SIGNATURE_SAVE, SIGNATURE_LOAD = 0x65766173, 0x64616F6C  # "save", "load" (CiA 301)

BLOCK_SIZE = 0x2000
TAB_FORMATI, TAB_CON_FORMATI, TAB_EXP_INT, TAB_EXP_OSC = 0x2001, 0x2002, 0x2003, 0x2004
TAB_PAR_DEF, TAB_CON_DEF = 0x2005, 0x2006
HW_SOFTWARE, HW_SENSORE, K_ZZ, VIA_ALLA_CONTA = 0x2007, 0x2008, 0x2009, 0x200A
TAB_MONITOR_A, TAB_MONITOR_B = 0x200B, 0x200C
TAB_PAR, TAB_CON, TAB_INT = 0x200D, 0x200E, 0x200F
TAB_INP_DIG, TAB_OUT_DIG, TAB_OSC = 0x2010, 0x2011, 0x2012
INGRESSI, INGRESSI_HW, USCITE_HW = 0x2013, 0x2014, 0x2015
TAB_INP_DIG_FIELD = 0x2016
STATO, ALLARMI, ABILITAZIONE_ALLARMI = 0x2017, 0x2018, 0x2019
F_FIELDBUS, LIMIT_FIELDBUS, TRIF_FIELDBUS, THETA_FIELDBUS = 0x201A, 0x201B, 0x201C, 0x201D
TAB_DATI_APPLICAZIONE = 0x201E
INGRESSI_STANDARD_WR, INGRESSI_APPL_WR = 0x201F, 0x2020
INGRESSI_STANDARD_RD, INGRESSI_APPL_RD, USCITE_LOGICHE_RD = 0x2021, 0x2022, 0x2023
WORD_VUOTA, DOUBLE_VUOTA = 0x2024, 0x2025
TAB_FORMATI_EXTRA = 0x2026

ARRAY_SIZES = {TAB_PAR: 200, TAB_CON: 100, TAB_INT: 64, TAB_INP_DIG: 32, TAB_OUT_DIG: 32, TAB_OSC: 64,
               TAB_INP_DIG_FIELD: 32, TAB_DATI_APPLICAZIONE: 100}
MONITOR_POINTS = 2000

HIGH = 32767  # a logic function's "high" in the INT16 tables
RUN = 0  # standard logic input function I00 "marcia"

SPEED_FULL_SCALE = 16384  # 0x201A: 16384 = 100 % n_MAX
TORQUE_FULL_SCALE = 4095  # 0x201B / 0x201C: 4095 = 100 % T_nom
PULSES_PER_REVOLUTION = 65536  # 0x201D (times the pole pairs: electrical)

EMCY_GENERIC = 0x1000  # "0x10xx" generic error (xx = 00)
EMCY_RESET = 0x0000  # "0x00xx" error reset / no error

# error register 0x1001 bits from the alarms (§2.6)
REGISTER_GROUPS = ((1 << 1, (3,)), (1 << 2, (10, 11, 13)), (1 << 3, (4, 5, 6)))

# SDO aborts: the appendix lists none (§2.2); these are the simulator's choices
ABORT_NO_SIZE = 0x05040001  # expedited download without the size indicator: "command specifier not valid"
ABORT_READ_ONLY = 0x06010002  # a parameter slot that is not managed (format class 0)
ABORT_NO_SUBINDEX = 0x06090011  # an array sub-index without an element (array_offset 0)
ABORT_INVALID_VALUE = 0x06090030  # reserved transmission type
ABORT_TOO_HIGH = 0x06090031
ABORT_TOO_LOW = 0x06090032
ABORT_NOT_STORED = 0x08000020  # wrong save/load signature; key P60 / P99 not set
ABORT_STATE = 0x08000022  # a Reserved / TDE parameter written while the drive runs


def register_of(alarms: int) -> int:
    """Error register 0x1001 for an alarm word (bit 0 any alarm, 1 A3, 2 A10/A11/A13, 3 A4-A6)."""
    if not alarms & 0xFFFF:
        return 0
    bits = 1
    for bit, group in REGISTER_GROUPS:
        if any(alarms >> n & 1 for n in group):
            bits |= bit
    return bits
