!> Kinds, status codes and stop reasons shared by the whole core.
!>
!> Every core routine reports failure through an integer status and a
!> message instead of stopping, so that Python and the batch program can
!> report the problem and carry on with the rest of a batch.
module mlid_kinds
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  implicit none
  private

  !> Working precision: C double, so f2py maps it without a kind map.
  integer, parameter, public :: wp = c_double
  !> Integer kind of the flat interface.
  integer, parameter, public :: ik = c_int
  !> Length of status messages.
  integer, parameter, public :: msg_len = 256

  !> Status codes (0 is success).
  integer, parameter, public :: MLID_OK = 0
  integer, parameter, public :: MLID_ERR_INPUT = 1     !< bad input: dimensions, values, options
  integer, parameter, public :: MLID_ERR_SINGULAR = 2  !< singular information or covariance
  integer, parameter, public :: MLID_ERR_DIVERGED = 3  !< state became non-finite
  integer, parameter, public :: MLID_ERR_NOCONV = 4    !< iteration ended without convergence
  integer, parameter, public :: MLID_ERR_INTERNAL = 5  !< LAPACK or other internal failure
  integer, parameter, public :: MLID_ERR_INTERRUPTED = 6  !< Ctrl-C (mlid_interrupt)
  integer, parameter, public :: MLID_ERR_MEMORY = 7    !< an allocation failed (not enough memory)

  !> Why a Newton iteration stopped.
  integer, parameter, public :: STOP_NONE = 0
  integer, parameter, public :: STOP_COST = 1       !< relative cost change below tolerance
  integer, parameter, public :: STOP_STEP = 2       !< relative step below tolerance
  integer, parameter, public :: STOP_GRAD = 3       !< Newton decrement below tolerance
  integer, parameter, public :: STOP_MAXITER = 4    !< iteration limit reached
  integer, parameter, public :: STOP_NO_DECREASE = 5 !< no cost decrease after all halvings
  integer, parameter, public :: STOP_FAILED = 6     !< an error ended the iteration
  integer, parameter, public :: STOP_DIVERGED = 7   !< it ended on a fit not sane (mlid_newton)

  !> What a fit that ended with a status and a stop reason has to show.
  integer, parameter, public :: FIT_ESTIMATES = 0  !< estimates and sigma, converged or not
  integer, parameter, public :: FIT_FAILED = 1     !< an error ended it: only the last values reached
  integer, parameter, public :: FIT_NOT_RUN = 2    !< bad input: nothing was fitted

  public :: stop_reason_text, first_failure, fit_outcome

contains

  !> Human-readable text for a stop reason.
  pure function stop_reason_text(reason) result(text)
    integer, intent(in) :: reason
    character(len=64) :: text
    select case (reason)
    case (STOP_COST);        text = 'relative cost change below tol_cost'
    case (STOP_STEP);        text = 'relative parameter step below tol_step'
    case (STOP_GRAD);        text = 'Newton decrement below tol_grad'
    case (STOP_MAXITER);     text = 'iteration limit reached'
    case (STOP_NO_DECREASE); text = 'no cost decrease after all step halvings'
    case (STOP_FAILED);      text = 'stopped by an error'
    case (STOP_DIVERGED);    text = 'diverged: R-hat or cost not sane'
    case default;            text = 'not started'
    end select
  end function stop_reason_text

  !> What a fit has to show (FIT_*).  Running out of iterations or of step
  !> halvings leaves a result (status MLID_ERR_NOCONV, reason MAXITER or
  !> NO_DECREASE) whose sigma still mean something, and a fit that diverged
  !> (reason DIVERGED) shows what it reached, as not converged; any other error, and a
  !> NOCONV from inside a step (the steady-state Riccati iteration), leaves
  !> no estimates: a singular information has no inverse, a diverged or
  !> non-positive-definite likelihood no value.
  pure integer function fit_outcome(status, reason)
    integer, intent(in) :: status, reason
    if (status == MLID_ERR_INPUT) then
      fit_outcome = FIT_NOT_RUN
    else if (status == MLID_OK .or. (status == MLID_ERR_NOCONV .and. reason /= STOP_FAILED)) then
      fit_outcome = FIT_ESTIMATES
    else
      fit_outcome = FIT_FAILED
    end if
  end function fit_outcome

  !> The first failure of work done in parallel (item by item, so the
  !> message does not depend on the threads): its status and message.
  pure subroutine first_failure(kstat, kmsg, status, msg)
    integer, intent(in) :: kstat(:)
    character(len=*), intent(in) :: kmsg(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k
    status = MLID_OK
    msg = ''
    k = findloc(kstat /= MLID_OK, .true., 1)
    if (k == 0) return
    status = kstat(k)
    msg = kmsg(k)
  end subroutine first_failure

end module mlid_kinds
