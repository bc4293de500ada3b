/* main.c — the squall command line (placeholder until the sub-commands land). */
#include <stdio.h>

#include "squall/core.h"

int main(void)
{
    printf("squall %s\n", sq_version());
    return 0;
}
