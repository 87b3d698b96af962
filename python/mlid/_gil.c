/* The GIL released while the core fits a deck case (mlid_run's hooks,
   given by fortran/api/mlid_api_deck.f90's mlid_deck_case_run): the call
   comes in holding the GIL, and the fit itself builds no text and touches
   nothing of Python's, as mlid_fit's released wrapper does. */
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
