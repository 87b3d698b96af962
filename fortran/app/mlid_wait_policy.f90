!> Passive waiting for mlid-batch's OpenMP threads, as mlid's Python
!> package asks for it (python/mlid/openmp.py, which says why: OpenMP's
!> default spins a waiting thread for milliseconds, and the core's parallel
!> regions are short and far apart).  libgomp reads OMP_WAIT_POLICY once,
!> when it is loaded, before this program starts; so when the environment
!> does not choose (neither OMP_WAIT_POLICY nor GOMP_SPINCOUNT set), the
!> program sets it and starts itself again, once, with the same arguments.
!> If that cannot be done (no /proc), it goes on as it is: only the CPU
!> time differs, not the values computed.
module mlid_wait_policy
  use, intrinsic :: iso_c_binding, only: c_char, c_int, c_ptr, c_loc, c_null_ptr, c_null_char
  implicit none
  private
  public :: wait_passive

  !> The variables by which the environment chooses how threads wait.
  character(len=*), parameter :: WAIT_VARIABLES(2) = ['OMP_WAIT_POLICY', 'GOMP_SPINCOUNT ']

  interface
    integer(c_int) function setenv(name, value, overwrite) bind(C, name='setenv')
      import :: c_char, c_int
      character(kind=c_char), intent(in) :: name(*), value(*)
      integer(c_int), value, intent(in) :: overwrite
    end function setenv
    integer(c_int) function execv(path, argv) bind(C, name='execv')
      import :: c_char, c_int, c_ptr
      character(kind=c_char), intent(in) :: path(*)
      type(c_ptr), intent(in) :: argv(*)
    end function execv
  end interface

contains

  !> Set OMP_WAIT_POLICY=passive and start again, unless the environment
  !> chooses; returns only when it does not start again.
  subroutine wait_passive()
    type :: c_string_t
      character(kind=c_char, len=:), allocatable :: s
    end type c_string_t
    type(c_string_t), allocatable, target :: args(:)
    type(c_ptr), allocatable :: argv(:)
    integer :: k, n, length, status

    do k = 1, size(WAIT_VARIABLES)
      call get_environment_variable(trim(WAIT_VARIABLES(k)), length=length, status=status)
      if (status /= 1) return                 ! set (even empty), or no environment
    end do
    if (setenv('OMP_WAIT_POLICY'//c_null_char, 'passive'//c_null_char, 1_c_int) /= 0) return
    n = command_argument_count()
    allocate (args(0:n), argv(0:n + 1))
    do k = 0, n
      call get_command_argument(k, length=length)
      allocate (character(kind=c_char, len=length + 1) :: args(k)%s)
      call get_command_argument(k, args(k)%s(1:length))
      args(k)%s(length + 1:) = c_null_char
      argv(k) = c_loc(args(k)%s)
    end do
    argv(n + 1) = c_null_ptr
    status = execv('/proc/self/exe'//c_null_char, argv)
  end subroutine wait_passive

end module mlid_wait_policy
