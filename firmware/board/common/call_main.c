/* C may call main(); ISO C++ may not. The start-up code calls main through this. */
int main(void);
int odoerr_call_main(void);
int odoerr_call_main(void) { return main(); }
