/* The GIL released while the core fits a deck case or runs its Monte Carlo
   (the job runner's hooks, given by fortran/api/mlid_api_deck.f90's
   mlid_deck_case_run): the call comes in holding the GIL, and that work
   builds no text and touches nothing of Python's, as mlid_fit's and
   mlid_monte_carlo's released wrappers do (a progress bar's thread reads
   its count meanwhile). */
#include <Python.h>

static _Thread_local PyThreadState *saved = NULL;

void mlid_gil_release(void)
{
    if (saved == NULL && PyGILState_Check())
        saved = PyEval_SaveThread();
}

void mlid_gil_restore(void)
{
    if (saved != NULL) {
        PyEval_RestoreThread(saved);
        saved = NULL;
    }
}
