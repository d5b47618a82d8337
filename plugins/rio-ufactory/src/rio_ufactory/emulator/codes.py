"""Numbers of the xArm controller protocol the emulator speaks: command registers, controller error
codes, states and modes. One table, so that the handlers, the fault injection and the tests name the
same things (the values are the controller's; the names are ours)."""

from __future__ import annotations

from enum import IntEnum


class Reg(IntEnum):
    """Command registers (the byte after the header of a request)."""

    GET_VERSION = 1
    GET_ROBOT_SN = 2
    CHECK_VERIFY = 3
    RELOAD_DYNAMICS = 4
    GET_REPORT_TAU_OR_I = 5
    GET_TCP_ROTATION_RADIUS = 6
    GET_ALLOW_APPROX_MOTION = 7
    SYSTEM_CONTROL = 10
    MOTION_EN = 11
    SET_STATE = 12
    GET_STATE = 13
    GET_CMDNUM = 14
    GET_ERROR = 15
    CLEAN_ERR = 16
    CLEAN_WAR = 17
    SET_BRAKE = 18
    SET_MODE = 19
    MOVE_LINE = 21
    MOVE_LINEB = 22
    MOVE_JOINT = 23
    MOVE_JOINTB = 24
    MOVE_HOME = 25
    SLEEP_INSTT = 26
    MOVE_CIRCLE = 27
    MOVE_LINE_TOOL = 28
    MOVE_SERVOJ = 29
    MOVE_SERVO_CART = 30
    SET_TCP_JERK = 31
    SET_TCP_MAXACC = 32
    SET_JOINT_JERK = 33
    SET_JOINT_MAXACC = 34
    SET_TCP_OFFSET = 35
    SET_LOAD_PARAM = 36
    SET_COLLIS_SENS = 37
    SET_TEACH_SENS = 38
    CLEAN_CONF = 39
    SAVE_CONF = 40
    GET_TCP_POSE = 41
    GET_JOINT_POS = 42
    GET_IK = 43
    GET_FK = 44
    IS_JOINT_LIMIT = 45
    IS_TCP_LIMIT = 46
    SET_REDUCED_TRSV = 47
    SET_REDUCED_P2PV = 48
    GET_REDUCED_MODE = 49
    SET_REDUCED_MODE = 50
    SET_GRAVITY_DIR = 51
    SET_LIMIT_XYZ = 52
    GET_REDUCED_STATE = 53
    GET_JOINT_TAU = 55
    SET_SAFE_LEVEL = 56
    GET_SAFE_LEVEL = 57
    SET_REDUCED_JRANGE = 58
    SET_FENSE_ON = 59
    SET_COLLIS_REB = 60
    SET_ALLOW_APPROX_MOTION = 66
    GET_MOVEMENT = 69
    REPORT_TAU_OR_I = 70
    SET_WORLD_OFFSET = 73
    CNTER_RESET = 74
    CNTER_PLUS = 75
    SET_SELF_COLLIS_CHECK = 77
    SET_COLLIS_TOOL = 78
    SET_SIMULATION_ROBOT = 79
    SET_CARTV_CONTINUE = 80
    GET_TCP_POSE_AA = 91
    TGPIO_MB_TIOUT = 123
    RS485_RTU = 124
    TGPIO_ERR = 125
    TGPIO_W16B = 127
    TGPIO_R16B = 128
    TGPIO_W32B = 129
    TGPIO_R32B = 130
    CGPIO_GET_DIGIT = 131
    CGPIO_GET_ANALOG1 = 132
    CGPIO_GET_ANALOG2 = 133
    CGPIO_SET_DIGIT = 134
    CGPIO_GET_STATE = 139
    GET_PWR_VERSION = 140
    GET_HD_TYPES = 141
    DELAYED_TGPIO_SET = 143
    SET_IO_STOP_RESET = 146
    TGPIO_COM_TIOUT = 240
    FEEDBACK_CHECK = 253
    SET_FEEDBACK_TYPE = 254


def reg_name(reg: int) -> str:
    try:
        return Reg(reg).name
    except ValueError:
        return f"register {reg}"


class State(IntEnum):
    """The controller's motion state (low nibble of the reports' state byte)."""

    START = 0  # requested by set_state(0); never reported
    MOVING = 1
    SLEEPING = 2  # ready, nothing to do
    PAUSED = 3
    STOPPED = 4


class Mode(IntEnum):
    POSITION = 0
    SERVO = 1
    JOINT_TEACH = 2
    JOINT_VELOCITY = 4
    CARTESIAN_VELOCITY = 5


class Err(IntEnum):
    """Controller error codes (C codes) the emulator raises."""

    ESTOP_BUTTON = 1  # the emergency stop button on the control box
    ESTOP_IO = 2  # the control box's emergency-stop input
    SERVO = 10  # servo motor error (no joint named)
    SERVO_1 = 11  # ... C11..C17: servo motor N error
    END_EFFECTOR_COMM = 19
    JOINT_LIMIT = 23  # joints angle exceed limit
    COLLISION = 31  # collision caused abnormal current


#: Faults `XArmEmulator.inject_fault` knows, with the C code each raises (servo: C11..C17 for joint
#: 1..7, C10 without a joint).
FAULTS = {
    "collision": Err.COLLISION,
    "joint_limit": Err.JOINT_LIMIT,
    "estop": Err.ESTOP_BUTTON,
    "estop_io": Err.ESTOP_IO,
    "servo": Err.SERVO,
}

#: Errors that cut the motors' power (the arm must be re-enabled after clean_error).
POWER_CUT = frozenset({Err.ESTOP_BUTTON, Err.ESTOP_IO, Err.SERVO, *range(11, 18)})
ESTOPS = frozenset({Err.ESTOP_BUTTON, Err.ESTOP_IO})

# feedback kinds (bits of SET_FEEDBACK_TYPE) and codes
FB_MOTION_START = 1
FB_MOTION_FINISH = 2
FB_TRIGGER = 4
FB_SUCCESS, FB_FAILURE, FB_DISCARD = 0, 1, 2
