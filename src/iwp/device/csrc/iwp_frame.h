/* iwp_frame.h: frames on the wire, 0x00 COBS(payload + CRC-16/CCITT-FALSE, big-endian) 0x00.
 * Portable C99, no allocation; the same framing as iwp.device.framing on the host. */
#ifndef IWP_FRAME_H
#define IWP_FRAME_H

#include <stdint.h>

/* CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF), one byte at a time, no table. */
uint16_t iwp_crc16_update(uint16_t crc, uint8_t byte);
uint16_t iwp_crc16(const uint8_t *data, uint16_t n);

/* COBS-encode n bytes of src into dst (room for n + n/254 + 1 bytes); returns the encoded length. */
uint16_t iwp_cobs_encode(const uint8_t *src, uint16_t n, uint8_t *dst);
/* COBS-decode n bytes (no delimiter) in place; returns the decoded length, or -1 if malformed. */
int16_t iwp_cobs_decode_inplace(uint8_t *buf, uint16_t n);

#endif
