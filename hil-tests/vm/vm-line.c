#define _DEFAULT_SOURCE /* cfmakeraw, CRTSCTS */
#include "vm-line.h"

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

int vm_open_line(const char *path)
{
	struct termios tio;
	int fd = open(path, O_RDWR | O_NOCTTY);

	if (fd < 0)
		return -1;
	if (tcgetattr(fd, &tio) == 0) { /* a virtio port is no terminal: nothing to set */
		cfmakeraw(&tio);
		tio.c_cflag |= CLOCAL | CREAD;
		tio.c_cflag &= ~(tcflag_t)CRTSCTS;
		cfsetispeed(&tio, B115200);
		cfsetospeed(&tio, B115200);
		tio.c_cc[VMIN] = 1;
		tio.c_cc[VTIME] = 0;
		if (tcsetattr(fd, TCSANOW, &tio) != 0) {
			close(fd);
			return -1;
		}
	}
	return fd;
}
