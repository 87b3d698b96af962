/* Ctrl-C for the core (fortran/base/mlid_interrupt.f90 is its Fortran
   side).  A front end arms SIGINT around its calls; a SIGINT then sets a
   flag, which the long loops of the core poll (a fit's samples and
   iterations, a Monte Carlo run, a design iteration) to unwind with the
   status 'interrupted'.  The flag is one per process: every call running
   when Ctrl-C comes is interrupted, and it is cleared when no armed call
   is left, so an interrupt never reaches a later call.

   Armed from Python (python/mlid/_bridge.py, around every call), the
   handler takes the place of Python's own only while calls run, and
   passes the signal on to it: Python then raises KeyboardInterrupt as
   soon as the call returns.  A SIGINT that is ignored, or left to its
   default, stays so there (the user asked for that).  mlid-batch arms it
   over the default: its cases end 'interrupted' and it exits; a second
   Ctrl-C there ends the process at once, as the default would. */
#include <pthread.h>
#include <signal.h>
#include <string.h>

/* Set by a SIGINT during an armed call; read by mlid_sigint_requested. */
static volatile sig_atomic_t requested = 0;
/* The handler ours took the place of (and passes the signal on to). */
static struct sigaction previous;
/* Calls running armed, and whether ours is installed: under lock. */
static int armed = 0, installed = 0;
static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;

static int passes_on(const struct sigaction *a)
{
    return (a->sa_flags & SA_SIGINFO) ||
           (a->sa_handler != SIG_DFL && a->sa_handler != SIG_IGN);
}

static void on_sigint(int sig, siginfo_t *info, void *context)
{
    if (requested && !passes_on(&previous)) {
        sigaction(SIGINT, &previous, NULL);   /* the second Ctrl-C: the default */
        raise(SIGINT);
        return;
    }
    requested = 1;
    if (previous.sa_flags & SA_SIGINFO)
        previous.sa_sigaction(sig, info, context);
    else if (passes_on(&previous))
        previous.sa_handler(sig);
}

static int is_ours(const struct sigaction *a)
{
    return (a->sa_flags & SA_SIGINFO) && a->sa_sigaction == on_sigint;
}

/* A call begins: the first of those running clears the flag and installs
   the handler, over a handler that is a function (Python's), or also over
   the default when over_default is non-zero (mlid-batch). */
void mlid_sigint_arm(int over_default)
{
    struct sigaction now, ours;
    pthread_mutex_lock(&lock);
    if (armed++ == 0) {
        requested = 0;
        installed = 0;
        if (sigaction(SIGINT, NULL, &now) == 0 && !is_ours(&now) &&
            (passes_on(&now) || (over_default && now.sa_handler == SIG_DFL))) {
            previous = now;
            memset(&ours, 0, sizeof ours);
            ours.sa_sigaction = on_sigint;
            ours.sa_mask = now.sa_mask;
            ours.sa_flags = SA_SIGINFO | (now.sa_flags & (SA_ONSTACK | SA_RESTART));
            installed = sigaction(SIGINT, &ours, NULL) == 0;
        }
    }
    pthread_mutex_unlock(&lock);
}

/* A call ends: the last one puts the handler back (unless someone put
   another in its place meanwhile) and clears the flag. */
void mlid_sigint_disarm(void)
{
    struct sigaction now;
    pthread_mutex_lock(&lock);
    if (armed > 0 && --armed == 0) {
        if (installed && sigaction(SIGINT, NULL, &now) == 0 && is_ours(&now))
            sigaction(SIGINT, &previous, NULL);
        installed = 0;
        requested = 0;
    }
    pthread_mutex_unlock(&lock);
}

/* Whether a SIGINT came during the armed calls running now. */
int mlid_sigint_requested(void)
{
    return requested != 0;
}
