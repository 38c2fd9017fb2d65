/* iwp_protocol.h: the wire protocol's dictionary for the firmware.
 * GENERATED from iwp.device.protocol by tools/gen_protocol_header.py: do not edit. */
#ifndef IWP_PROTOCOL_H
#define IWP_PROTOCOL_H

#define IWP_PROTOCOL_VERSION 3
#define IWP_DICT_HASH 0xc1c31ac8UL
#define IWP_MAX_PAYLOAD 64

/* messages: type byte, payload size, byte offset of each field (little-endian, packed) */
#define IWP_MSG_HELLO 0x01
#define IWP_MSG_HELLO_SIZE 3
#define IWP_OFF_HELLO_NONCE 1 /* uint16_t, - */
#define IWP_MSG_GET_PARAM 0x02
#define IWP_MSG_GET_PARAM_SIZE 4
#define IWP_OFF_GET_PARAM_REQ 1 /* uint16_t, - */
#define IWP_OFF_GET_PARAM_PARAM 3 /* uint8_t, - */
#define IWP_MSG_SET_PARAM 0x03
#define IWP_MSG_SET_PARAM_SIZE 8
#define IWP_OFF_SET_PARAM_REQ 1 /* uint16_t, - */
#define IWP_OFF_SET_PARAM_PARAM 3 /* uint8_t, - */
#define IWP_OFF_SET_PARAM_VALUE 4 /* float, param */
#define IWP_MSG_ARM 0x04
#define IWP_MSG_ARM_SIZE 3
#define IWP_OFF_ARM_REQ 1 /* uint16_t, - */
#define IWP_MSG_DISARM 0x05
#define IWP_MSG_DISARM_SIZE 3
#define IWP_OFF_DISARM_REQ 1 /* uint16_t, - */
#define IWP_MSG_ESTOP 0x06
#define IWP_MSG_ESTOP_SIZE 3
#define IWP_OFF_ESTOP_REQ 1 /* uint16_t, - */
#define IWP_MSG_CLEAR 0x07
#define IWP_MSG_CLEAR_SIZE 3
#define IWP_OFF_CLEAR_REQ 1 /* uint16_t, - */
#define IWP_MSG_ZERO 0x08
#define IWP_MSG_ZERO_SIZE 4
#define IWP_OFF_ZERO_REQ 1 /* uint16_t, - */
#define IWP_OFF_ZERO_MASK 3 /* uint8_t, - */
#define IWP_MSG_COMMAND 0x09
#define IWP_MSG_COMMAND_SIZE 13
#define IWP_OFF_COMMAND_SEQ 1 /* uint32_t, - */
#define IWP_OFF_COMMAND_TICK 5 /* uint32_t, - */
#define IWP_OFF_COMMAND_U 9 /* float, input units */
#define IWP_MSG_HEARTBEAT 0x0a
#define IWP_MSG_HEARTBEAT_SIZE 9
#define IWP_OFF_HEARTBEAT_SEQ 1 /* uint32_t, - */
#define IWP_OFF_HEARTBEAT_TICK 5 /* uint32_t, - */
#define IWP_MSG_MODE 0x0b
#define IWP_MSG_MODE_SIZE 4
#define IWP_OFF_MODE_REQ 1 /* uint16_t, - */
#define IWP_OFF_MODE_MODE 3 /* uint8_t, - */
#define IWP_MSG_FIXTURE 0x0d
#define IWP_MSG_FIXTURE_SIZE 8
#define IWP_OFF_FIXTURE_REQ 1 /* uint16_t, - */
#define IWP_OFF_FIXTURE_ACTION 3 /* uint8_t, - */
#define IWP_OFF_FIXTURE_Q1 4 /* float, rad */
#define IWP_MSG_STREAM 0x0c
#define IWP_MSG_STREAM_SIZE 4
#define IWP_OFF_STREAM_REQ 1 /* uint16_t, - */
#define IWP_OFF_STREAM_EVERY 3 /* uint8_t, ticks */
#define IWP_MSG_IDENT 0x81
#define IWP_MSG_IDENT_SIZE 26
#define IWP_OFF_IDENT_NONCE 1 /* uint16_t, - */
#define IWP_OFF_IDENT_PROTOCOL 3 /* uint8_t, - */
#define IWP_OFF_IDENT_FW_MAJOR 4 /* uint8_t, - */
#define IWP_OFF_IDENT_FW_MINOR 5 /* uint8_t, - */
#define IWP_OFF_IDENT_FW_PATCH 6 /* uint8_t, - */
#define IWP_OFF_IDENT_BOARD 7 /* uint8_t, - */
#define IWP_OFF_IDENT_CAPS 8 /* uint16_t, - */
#define IWP_OFF_IDENT_DICT_HASH 10 /* uint32_t, - */
#define IWP_OFF_IDENT_PARAMS_HASH 14 /* uint32_t, - */
#define IWP_OFF_IDENT_BASE_US 18 /* uint32_t, us */
#define IWP_OFF_IDENT_TICK 22 /* uint32_t, ticks */
#define IWP_MSG_ACK 0x82
#define IWP_MSG_ACK_SIZE 10
#define IWP_OFF_ACK_REQ 1 /* uint16_t, - */
#define IWP_OFF_ACK_MSG 3 /* uint8_t, - */
#define IWP_OFF_ACK_CODE 4 /* uint8_t, - */
#define IWP_OFF_ACK_PARAM 5 /* uint8_t, - */
#define IWP_OFF_ACK_VALUE 6 /* float, param */
#define IWP_MSG_TELEMETRY 0x83
#define IWP_MSG_TELEMETRY_SIZE 45
#define IWP_OFF_TELEMETRY_SEQ 1 /* uint32_t, ticks */
#define IWP_OFF_TELEMETRY_T_US 5 /* uint32_t, us */
#define IWP_OFF_TELEMETRY_COUNT1 9 /* int32_t, counts */
#define IWP_OFF_TELEMETRY_COUNT2 13 /* int32_t, counts */
#define IWP_OFF_TELEMETRY_Q4 17 /* float, rad/s */
#define IWP_OFF_TELEMETRY_U 21 /* float, input units */
#define IWP_OFF_TELEMETRY_V 25 /* float, input units */
#define IWP_OFF_TELEMETRY_CURRENT 29 /* float, A */
#define IWP_OFF_TELEMETRY_STATE 33 /* uint8_t, - */
#define IWP_OFF_TELEMETRY_FAULT 34 /* uint8_t, - */
#define IWP_OFF_TELEMETRY_FLAGS 35 /* uint16_t, - */
#define IWP_OFF_TELEMETRY_OVERRUNS 37 /* uint16_t, - */
#define IWP_OFF_TELEMETRY_LATE 39 /* uint16_t, - */
#define IWP_OFF_TELEMETRY_RX_ERRORS 41 /* uint16_t, - */
#define IWP_OFF_TELEMETRY_DROPPED 43 /* uint16_t, - */

#define IWP_STATE_DISARMED 0
#define IWP_STATE_ARMED 1
#define IWP_STATE_FAULT 2
#define IWP_STATE_ESTOP 3

#define IWP_FAULT_NONE 0
#define IWP_FAULT_WATCHDOG 1
#define IWP_FAULT_Q1_LIMIT 2
#define IWP_FAULT_Q4_LIMIT 3
#define IWP_FAULT_DUTY_LIMIT 4
#define IWP_FAULT_ESTOP 5
#define IWP_FAULT_HOST 6

#define IWP_FLAG_SATURATED 1
#define IWP_FLAG_LATE 2
#define IWP_FLAG_QUEUE_FULL 4
#define IWP_FLAG_CURRENT_VALID 8
#define IWP_FLAG_HOST_CLOCK 16

#define IWP_CAP_HOST_CLOCK 1
#define IWP_CAP_CURRENT 2
#define IWP_CAP_HOPF 4
#define IWP_CAP_STATE_FEEDBACK 8
#define IWP_CAP_FIXTURE 16

#define IWP_MODE_HOST 0
#define IWP_MODE_HOPF 1
#define IWP_MODE_STATE_FEEDBACK 2

#define IWP_ACK_OK 0
#define IWP_ACK_BAD_PARAM 1
#define IWP_ACK_OUT_OF_RANGE 2
#define IWP_ACK_ARMED 3
#define IWP_ACK_FAULT 4
#define IWP_ACK_LIMIT 5
#define IWP_ACK_BAD_MODE 6

#define IWP_FIXTURE_RELEASE 0
#define IWP_FIXTURE_CLAMP 1
#define IWP_FIXTURE_HOLD 2

/* parameters: id, then IWP_PARAM_TABLE rows {default, lo, hi} in id order */
#define IWP_P_PERIOD_US 0 /* us: loop period (a multiple of IDENT base_us) */
#define IWP_P_WATCHDOG_MS 1 /* ms: motor off when no valid COMMAND/HEARTBEAT for this long */
#define IWP_P_V_MAX 2 /* input units: driver saturation |v| <= v_max (100: full duty) */
#define IWP_P_V_DZ_POS 3 /* input units: feedforward (7)-(8) threshold for u > 0 (0: none) */
#define IWP_P_V_DZ_NEG 4 /* input units: feedforward (7)-(8) threshold for u < 0 (0: none) */
#define IWP_P_Q1_MAX 5 /* rad: fault when |q1| exceeds it */
#define IWP_P_Q4_MAX 6 /* rad/s: fault when |q4| exceeds it (300: within what the AVR firmware counts exactly at 200 Hz) */
#define IWP_P_SAT_MS_MAX 7 /* ms: stall: fault when the command stays saturated with |q4| < q4_max/10 this long (0: off) */
#define IWP_P_COUNTS1 8 /* counts/rev: pendulum encoder resolution */
#define IWP_P_COUNTS2 9 /* counts/rev: wheel encoder resolution */
#define IWP_P_K1 10 /* input units s/rad: Hopf law u = k1 q3 + k2 q3^3 (section 5.3) */
#define IWP_P_K2 11 /* input units s^3/rad^3: Hopf law cubic gain */
#define IWP_P_FILTER_TAU 12 /* s: first-order filter of the q3 estimate (0: none) */
#define IWP_P_K_Q1 13 /* input units/rad: state feedback u = -(K_q1 e + K_q3 q3 + K_q4 q4), e = q1 - q1_ref wrapped to [-pi, pi) */
#define IWP_P_K_Q3 14 /* input units s/rad: state feedback gain on q3 */
#define IWP_P_K_Q4 15 /* input units s/rad: state feedback gain on q4 */
#define IWP_P_Q1_REF 16 /* rad: state feedback set point (pi: upright) */
#define IWP_P_U_MAX 17 /* input units: on-device laws: |u| <= u_max before the feedforward */
#define IWP_P_HOST_CLOCK 18 /* -: 1: tick as soon as the next tick's command is queued (emulator only, CAPS HOST_CLOCK); never slower than real time */
#define IWP_N_PARAMS 19
#define IWP_PARAM_TABLE { \
    {5000.0f, 1000.0f, 20000.0f}, \
    {100.0f, 10.0f, 2000.0f}, \
    {100.0f, 0.0f, 100.0f}, \
    {31.0f, 0.0f, 100.0f}, \
    {31.0f, 0.0f, 100.0f}, \
    {12.566370614359172f, 0.1f, 1000.0f}, \
    {300.0f, 1.0f, 10000.0f}, \
    {3000.0f, 0.0f, 60000.0f}, \
    {2000.0f, 1.0f, 1000000.0f}, \
    {2000.0f, 1.0f, 1000000.0f}, \
    {-10.0f, -10000.0f, 10000.0f}, \
    {0.1f, -10000.0f, 10000.0f}, \
    {0.01f, 0.0f, 1.0f}, \
    {0.0f, -1000000.0f, 1000000.0f}, \
    {0.0f, -1000000.0f, 1000000.0f}, \
    {0.0f, -1000000.0f, 1000000.0f}, \
    {3.141592653589793f, -10.0f, 10.0f}, \
    {100.0f, 0.0f, 100.0f}, \
    {0.0f, 0.0f, 1.0f} }

#endif /* IWP_PROTOCOL_H */
