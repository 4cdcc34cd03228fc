"""The OPEN drive's objects and numbers the bridge uses (shared/drives/opendrive.md §2-§3).

CiA 301 only: no CiA 402 object exists on this drive. The manufacturer area 0x2000-0x2026
holds the RUN logic, the references, the alarm words and the parameter arrays.
"""
from __future__ import annotations

# -- logic input functions (§3.6) --------------------------------------------------------
INPUTS_FIELDBUS = 0x2016  # Tab_inp_dig_field[32], INT16 0 / 32767; element 0 (RUN) starts high
INPUTS_STANDARD_WR = 0x201F  # Ingressi_standard_wr, U32: the 32 standard functions, bit k = Ik
INPUTS_STANDARD_RD = 0x2021  # Ingressi_standard_rd, U32: their state (RUN = terminal AND fieldbus AND serial)
INPUTS_STATE = 0x2010  # Tab_inp_dig[32], INT16 0 / 32767
RUN_FUNCTION = 0  # I00 "marcia": the enable
RUN_BIT = 1 << RUN_FUNCTION
LOGIC_HIGH = 32767  # a logic function element of 0x2016 / 0x2010 that is high

# -- alarms (§3.8) -----------------------------------------------------------------------
ALARMS = 0x2018  # allarmi, U16: bit n = alarm An
ALARM_ENABLE = 0x2019  # abilitazione_allarmi, U16 (written through P163)
STATUS = 0x2017  # stato, U16: its bit table is not in the appendix

# -- references (§3.9): acted upon only with C52 = 1 --------------------------------------
SPEED_REFERENCE = 0x201A  # f_fieldbus, INT16: 16384 = n_MAX
TORQUE_LIMIT = 0x201B  # limit_fieldbus, INT16: 4095 = T_nom
TORQUE_REFERENCE = 0x201C  # trif_fieldbus, INT16: 4095 = T_nom
SPEED_INCREMENT = 0x201D  # theta_fieldbus, INT16: electrical angle per PWM period (65536 x pole pairs / rev)
SPEED_REFERENCES = (SPEED_REFERENCE, SPEED_INCREMENT)

# -- actual values (§3.3, §3.4): which element is which quantity is not in the appendix ---
TAB_INT = 0x200F  # internal quantities, INT16[64] (format 0x2003)
TAB_OSC = 0x2012  # monitor quantities, INT16[64] (format 0x2004)
TABLES = {'tab_osc': TAB_OSC, 'tab_int': TAB_INT}
TABLE_ELEMENTS = 64

# -- parameters (§3.2) -------------------------------------------------------------------
FORMATS_P = 0x2001  # DOMAIN, 200 x 4 words: format, min, max, base
FORMATS_C = 0x2002  # DOMAIN, 100 x 4 words (base always 1)
FORMATS_EXTRA = 0x2026  # DOMAIN, 100 x 5 words (format, min, max, base, default): no values anywhere
PARAMETERS = 0x200D  # Tab_par[200], INT16: Pk at element k
CONNECTIONS = 0x200E  # Tab_con[100], INT16: Ck at element k
P_COUNT = 200
C_COUNT = 100
P60 = 60  # the key of the Reserved parameters
P99 = 99  # the key of the TDE parameters
C52 = 52  # 1: the references 0x201A-0x201D come from CAN
C63 = 63  # 1: save the parameters to non-volatile memory

# -- PWM and life guarding (§2.1) --------------------------------------------------------
LIFE_TIME_CLAMP = 32767  # the node life time is clamped to 32767 / f_pwm seconds
GUARD_TIME = 0x100C
LIFE_TIME_FACTOR = 0x100D

# -- EMCY (§2.6) -------------------------------------------------------------------------
EMCY_GENERIC_ERROR = 0x1000  # 0x10xx
EMCY_RESET = 0x0000  # 0x00xx

INT16_MIN = -0x8000
INT16_MAX = 0x7FFF
