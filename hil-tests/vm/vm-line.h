/* A tunnel's line in the VM (a serial port or a virtio-serial port), opened for binary: the CAN and
 * USB tunnels' bridges (swell-vm-canbridge, swell-vm-usbip-bridge). */
#ifndef SWELL_VM_LINE_H
#define SWELL_VM_LINE_H

/* Raw 8-bit, no echo, no CR/LF translation, no flow control. The fd, or -1 (errno set). */
int vm_open_line(const char *path);

#endif
